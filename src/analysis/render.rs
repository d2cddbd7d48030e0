//! Rendering hits on drawn objects as every judge hears them — `tactus eval`, its spectrograms,
//! the fit's velocity and attack checks: one impact on a new object per seed, through the real
//! [`Engine`].

use crate::engine::{Engine, Event, Settings};
use crate::preset::Preset;

/// Sample rate of the rendered draws, Hz.
pub const RENDER_FS: f64 = 44_100.0;
/// Length of a rendered draw without recordings to match, s.
pub const RENDER_S: f64 = 2.5;
/// Bounds of a draw's length, s, when it follows its recordings ([`seconds_like`]).
pub const RENDER_S_RANGE: (f64, f64) = (0.1, 10.0);
/// One hit as the judges render it: an impact at t = 0 at `speed_m_per_s` (pitch factor 1, no
/// key), played with `settings` for `seconds` at `fs` in blocks of `block` samples.
#[derive(Debug, Clone, Copy)]
pub struct Hit<'a> {
    /// Engine settings.
    pub settings: &'a Settings,
    /// Striker speed, m/s.
    pub speed_m_per_s: f64,
    /// Sample rate, Hz.
    pub fs: f64,
    /// Length, s.
    pub seconds: f64,
    /// Processing block, samples.
    pub block: usize,
}

impl Hit<'_> {
    /// The default hit `tactus eval` judges: 1 m/s at default settings, [`RENDER_FS`], 512-sample
    /// blocks, `seconds` long.
    pub fn default_for(seconds: f64) -> Hit<'static> {
        static DEFAULT: std::sync::OnceLock<Settings> = std::sync::OnceLock::new();
        Hit {
            settings: DEFAULT.get_or_init(Settings::default),
            speed_m_per_s: 1.0,
            fs: RENDER_FS,
            seconds,
            block: 512,
        }
    }
}

/// `hit` on the object `Engine::new(preset, 4, seed)` draws. Returns the engine (its object,
/// for the drawn modes) and the left and right channels.
pub fn render_hit(preset: &Preset, seed: u64, hit: &Hit) -> (Engine, Vec<f32>, Vec<f32>) {
    let total = (hit.seconds * hit.fs) as usize;
    let block = hit.block;
    let mut e = Engine::new(preset, 4, seed);
    e.prepare(hit.fs, block);
    let (mut l, mut r) = (vec![0f32; total], vec![0f32; total]);
    let mut pos = 0;
    while pos < total {
        let n = block.min(total - pos);
        let strike = [Event::Impact {
            offset: 0,
            velocity_m_per_s: hit.speed_m_per_s,
            pitch_factor: 1.0,
            key: -1,
        }];
        let ev: &[Event] = if pos == 0 { &strike } else { &[] };
        e.process(hit.settings, ev, &mut l[pos..pos + n], &mut r[pos..pos + n]);
        pos += n;
    }
    (e, l, r)
}

/// [`render_hit`] as mono `(L + R) / 2`, as the recordings were mixed.
pub fn render_mono(preset: &Preset, seed: u64, hit: &Hit) -> Vec<f64> {
    let (_, l, r) = render_hit(preset, seed, hit);
    l.iter()
        .zip(&r)
        .map(|(&a, &b)| 0.5 * (f64::from(a) + f64::from(b)))
        .collect()
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

/// Draw `seed` of `preset`: the default hit ([`Hit::default_for`]), `seconds` long, as mono.
pub fn render_draw(preset: &Preset, seed: u64, seconds: f64) -> Vec<f64> {
    render_mono(preset, seed, &Hit::default_for(seconds))
}
