//! Rendering a preset's draws as `tactus eval` and its spectrograms hear them: one default hit
//! on a new object per seed, through the real [`Engine`].

use crate::engine::{Engine, Event, Settings};
use crate::preset::Preset;

/// Sample rate of the rendered draws, Hz.
pub const RENDER_FS: f64 = 44_100.0;
/// Length of a rendered draw, s: the recordings last 0.1–3.3 s and the strongest partials'
/// T60 stays below ~2 s, so the energy left after 2.5 s is negligible for every feature.
pub const RENDER_S: f64 = 2.5;
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

/// Draw `seed` of `preset` at default settings as mono `(L + R) / 2` (as the recordings were
/// mixed), [`RENDER_S`] at [`RENDER_FS`].
pub fn render_draw(preset: &Preset, seed: u64) -> Vec<f64> {
    let (_, l, r) = render_one_hit(preset, seed, &Settings::default(), RENDER_FS, RENDER_S, 512);
    l.iter()
        .zip(&r)
        .map(|(&a, &b)| 0.5 * (f64::from(a) + f64::from(b)))
        .collect()
}
