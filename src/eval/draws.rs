//! Rendering a preset's draws as `tactus eval` and its spectrograms hear them: one default hit
//! on a new object per seed, through the real [`Engine`].

use crate::engine::{Engine, Event, Settings};
use crate::preset::Preset;

/// Sample rate of the rendered draws, Hz.
pub const RENDER_FS: f64 = 44_100.0;
/// Length of a rendered draw without recordings to match, s.
pub const RENDER_S: f64 = 2.5;
/// Bounds of a draw's length, s, when it follows its recordings ([`seconds_like`]).
pub const RENDER_S_RANGE: (f64, f64) = (0.1, 10.0);
/// One impact at t = 0 (1 m/s, pitch factor 1, no key) on the object `Engine::new(preset, 4,
/// seed)` draws, rendered with `settings` for `seconds` at `fs` in blocks of `block` samples.
/// Returns the engine (its object, for the drawn modes) and the left and right channels.
pub fn render_one_hit(
    preset: &Preset,
    seed: u64,
    settings: &Settings,
    fs: f64,
    seconds: f64,
    block: usize,
) -> (Engine, Vec<f32>, Vec<f32>) {
    let total = (seconds * fs) as usize;
    let mut e = Engine::new(preset, 4, seed);
    e.prepare(fs, block);
    let (mut l, mut r) = (vec![0f32; total], vec![0f32; total]);
    let mut pos = 0;
    while pos < total {
        let n = block.min(total - pos);
        let ev: &[Event] = if pos == 0 {
            &[Event::Impact {
                offset: 0,
                velocity_m_per_s: 1.0,
                pitch_factor: 1.0,
                key: -1,
            }]
        } else {
            &[]
        };
        e.process(settings, ev, &mut l[pos..pos + n], &mut r[pos..pos + n]);
        pos += n;
    }
    (e, l, r)
}

/// How long to render draws judged against recordings of these lengths (s): their median, within
/// [`RENDER_S_RANGE`]; [`RENDER_S`] without any. A draw is cut where its recordings were cut,
/// so the energy features (attack share, early decay time) see the same span of both: a 2.5 s
/// draw of a cymbal whose recordings run 6 s would lose its tail's energy and read as all attack.
pub fn seconds_like(durations: impl IntoIterator<Item = f64>) -> f64 {
    let d: Vec<f64> = durations
        .into_iter()
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    if d.is_empty() {
        return RENDER_S;
    }
    crate::stats::median(&d).clamp(RENDER_S_RANGE.0, RENDER_S_RANGE.1)
}

/// Draw `seed` of `preset` at default settings as mono `(L + R) / 2` (as the recordings were
/// mixed), `seconds` at [`RENDER_FS`].
pub fn render_draw(preset: &Preset, seed: u64, seconds: f64) -> Vec<f64> {
    let (_, l, r) = render_one_hit(preset, seed, &Settings::default(), RENDER_FS, seconds, 512);
    l.iter()
        .zip(&r)
        .map(|(&a, &b)| 0.5 * (f64::from(a) + f64::from(b)))
        .collect()
}
