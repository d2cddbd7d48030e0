//! Can a listener's ear tell the measured surfaces apart in a scrape? (docs/measured.md,
//! "Telling the surfaces apart"). Scrapes at one speed and pressure on each measured surface,
//! the same object every time (only the surface's synthesised stretch changes with the seed),
//! measured by their spectrum (third-octave band levels) and their impulsiveness (kurtosis),
//! judged by a nearest-centre classifier with each scrape left out of its own training
//! ([`super::confusion`]).
//!
//! Which pairs should be told apart: those whose measured height spectra differ by more than
//! [`DISTINCT_DB`] in some octave band that reaches the ear at the scrape's speed (a spatial
//! frequency `k` cycles/m sounds at `v·k` Hz; audible: 20 Hz – 20 kHz).

use super::confusion::{leave_one_out, pairwise_share, Confusion};
use crate::analysis::surfaces::octave_db_of;
use crate::engine::sustained::measured::{band_edges_per_m, OCTAVES};
use crate::engine::sustained::SurfaceKind;
use rayon::prelude::*;
use realfft::RealFftPlanner;

/// Scraping speed of every render, m/s: the engine's default. At it the six octave bands of
/// the measured spectra (0.5–16 /mm) sound at 150 Hz – 4.8 kHz.
pub const SPEED_M_PER_S: f64 = 0.3;
/// Pressure of every render, N: the engine's default.
pub const PRESSURE_N: f64 = 5.0;
/// The scraped object: a built-in material (its default object, one draw for every render).
pub const MATERIAL: &str = "wood";
/// Seed of the one object every scrape is played on.
pub const OBJECT_SEED: u64 = 1;
/// Sample rate, Hz.
pub const FS: f64 = 48_000.0;
/// Length of a render, s.
pub const SECONDS: f64 = 1.5;
/// Start of the analysed span, s: after the scrape's onset ramp.
pub const SKIP_S: f64 = 0.25;
/// A pair of surfaces is expected to be told apart when their measured octave-band height
/// spectra differ by more than this somewhere audible, dB.
pub const DISTINCT_DB: f64 = 3.0;
/// Audible band, Hz.
pub const AUDIBLE_HZ: (f64, f64) = (20.0, 20_000.0);
/// Third-octave bands of the features: centres `1 kHz · 2^(k/3)` for these k (100 Hz – 12.5 kHz).
const FEATURE_BANDS: std::ops::RangeInclusive<i32> = -10..=11;
/// Analysis frame (Hann), samples.
const FRAME: usize = 4096;

/// The measured surfaces, in [`SurfaceKind::ALL`] order.
pub fn measured_surfaces() -> Vec<SurfaceKind> {
    SurfaceKind::ALL
        .iter()
        .copied()
        .filter(|k| k.stats().is_some())
        .collect()
}

/// A scrape of [`SECONDS`] on `surface` at [`SPEED_M_PER_S`] and [`PRESSURE_N`] on
/// [`MATERIAL`]'s object [`OBJECT_SEED`], through the scene renderer; `seed` draws the
/// surface's stretches. Mono (the channels' mean), at [`FS`].
pub fn render_scrape(surface: SurfaceKind, seed: u64) -> Vec<f64> {
    let scene = serde_json::json!({
        "sample_rate": FS as u32,
        "duration_s": SECONDS,
        "seed": seed,
        "material": MATERIAL,
        "events": [
            {"type": "new_object", "time_s": 0.0, "seed": OBJECT_SEED},
            {"type": "scrape", "time_s": 0.0, "duration_s": SECONDS,
             "speed_m_per_s": SPEED_M_PER_S, "pressure_n": PRESSURE_N, "surface": surface.name()}
        ]
    });
    let loaded = crate::scene::Scene::from_value(scene, None).expect("a valid scrape scene");
    let (l, r) = crate::scene::render(&loaded, 512);
    l.iter()
        .zip(&r)
        .map(|(&a, &b)| 0.5 * (f64::from(a) + f64::from(b)))
        .collect()
}

/// Features of a scrape `x` at `fs` from [`SKIP_S`]: third-octave band levels (dB of the
/// Welch-averaged power, 100 Hz – 12.5 kHz) and log10 of the kurtosis of the signal (a
/// grainy surface's scrape is impulsive).
pub fn scrape_features(x: &[f64], fs: f64) -> Vec<f64> {
    let y = &x[((SKIP_S * fs) as usize).min(x.len())..];
    let win: Vec<f64> = (0..FRAME)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / FRAME as f64).cos())
        .collect();
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(FRAME);
    let mut spec = fft.make_output_vec();
    let mut psd = vec![0.0; spec.len()];
    let mut frames = 0usize;
    for start in (0..y.len().saturating_sub(FRAME)).step_by(FRAME / 2) {
        let mut buf: Vec<f64> = y[start..start + FRAME]
            .iter()
            .zip(&win)
            .map(|(a, w)| a * w)
            .collect();
        let _ = fft.process(&mut buf, &mut spec);
        for (p, s) in psd.iter_mut().zip(&spec) {
            *p += s.norm_sqr();
        }
        frames += 1;
    }
    let hz_per_bin = fs / FRAME as f64;
    let mut out: Vec<f64> = FEATURE_BANDS
        .map(|k| {
            let c = 1000.0 * 2f64.powf(k as f64 / 3.0);
            let (lo, hi) = (c * 2f64.powf(-1.0 / 6.0), c * 2f64.powf(1.0 / 6.0));
            let p: f64 = psd
                .iter()
                .enumerate()
                .filter(|(i, _)| (lo..hi).contains(&(*i as f64 * hz_per_bin)))
                .map(|(_, p)| p)
                .sum();
            10.0 * (p / frames.max(1) as f64).max(1e-30).log10()
        })
        .collect();
    let n = y.len().max(1) as f64;
    let m = y.iter().sum::<f64>() / n;
    let var = y.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n;
    let m4 = y.iter().map(|v| (v - m).powi(4)).sum::<f64>() / n;
    out.push((m4 / (var * var).max(1e-300)).max(1e-9).log10());
    out
}

/// Octave-band height levels (dB re 1 µm²) of `kind`'s measured spectrum.
fn octaves(kind: SurfaceKind) -> [f64; OCTAVES] {
    octave_db_of(&kind.stats().expect("a measured surface").band_db)
}

/// Whether octave `o` of the measured spectra sounds inside [`AUDIBLE_HZ`] at `speed_m_per_s`
/// (its band edges, three third-octaves, as `v·k` Hz).
pub fn octave_audible(o: usize, speed_m_per_s: f64) -> bool {
    let lo = band_edges_per_m(3 * o).0 * speed_m_per_s;
    let hi = band_edges_per_m(3 * o + 2).1 * speed_m_per_s;
    hi > AUDIBLE_HZ.0 && lo < AUDIBLE_HZ.1
}

/// The largest difference, dB, between the measured octave-band spectra of `a` and `b` over the
/// octaves audible at `speed_m_per_s`.
pub fn spectral_difference_db(a: SurfaceKind, b: SurfaceKind, speed_m_per_s: f64) -> f64 {
    let (x, y) = (octaves(a), octaves(b));
    (0..OCTAVES)
        .filter(|&o| octave_audible(o, speed_m_per_s))
        .map(|o| (x[o] - y[o]).abs())
        .fold(0.0, f64::max)
}

/// One pair of surfaces: their measured spectra's largest audible difference and how often the
/// scrapes of either were given their own surface in a choice between the two.
#[derive(Debug, Clone)]
pub struct Pair {
    /// The surfaces.
    pub a: SurfaceKind,
    /// The surfaces.
    pub b: SurfaceKind,
    /// [`spectral_difference_db`].
    pub difference_db: f64,
    /// Share told apart ([`pairwise_share`]).
    pub share: f64,
}

/// The surfaces' recognition: the 12-way confusion matrix (each scrape left out of its own
/// training) and every pair.
#[derive(Debug, Clone)]
pub struct SurfaceRecognition {
    /// Rows: the surface scraped; columns: the surface judged.
    pub confusion: Confusion,
    /// Every pair of measured surfaces.
    pub pairs: Vec<Pair>,
}

/// Renders `per_surface` scrapes (seeds `1..=per_surface`) on every measured surface, in
/// parallel, and judges them ([`SurfaceRecognition`]).
pub fn recognise(per_surface: usize) -> SurfaceRecognition {
    let kinds = measured_surfaces();
    let jobs: Vec<(usize, u64)> = (0..kinds.len())
        .flat_map(|i| (1..=per_surface as u64).map(move |s| (i, s)))
        .collect();
    let items: Vec<(usize, Vec<f64>)> = jobs
        .par_iter()
        .map(|&(i, seed)| (i, scrape_features(&render_scrape(kinds[i], seed), FS)))
        .collect();
    let names: Vec<&str> = kinds.iter().map(|k| k.name()).collect();
    let (confusion, dists) = leave_one_out(&names, &items);
    let mut pairs = Vec::new();
    for a in 0..kinds.len() {
        for b in a + 1..kinds.len() {
            pairs.push(Pair {
                a: kinds[a],
                b: kinds[b],
                difference_db: spectral_difference_db(kinds[a], kinds[b], SPEED_M_PER_S),
                share: pairwise_share(&items, &dists, a, b),
            });
        }
    }
    SurfaceRecognition { confusion, pairs }
}

/// Writes `measured-surfaces.png` into `out_dir`: a scrape ([`render_scrape`], seed 1) on each
/// measured surface, four to a row. Returns the file written.
pub fn write_surface_sheet(out_dir: &std::path::Path) -> anyhow::Result<std::path::PathBuf> {
    use super::spectrogram::{write_grid, Layout, Panel};
    let kinds = measured_surfaces();
    let scrapes: Vec<Vec<f64>> = kinds.par_iter().map(|&k| render_scrape(k, 1)).collect();
    let panels: Vec<Panel> = kinds
        .iter()
        .zip(&scrapes)
        .map(|(k, x)| Panel {
            title: k.name().to_owned(),
            samples: x,
            fs: FS,
        })
        .collect();
    // Small panels over 0.5 s: a scrape's spectrogram is noise, which a PNG barely compresses,
    // and half a second shows its texture as well as the whole render.
    let layout = Layout {
        columns: 4,
        span_s: 0.5,
        band_hz: (50.0, 16_000.0),
        panel_px: (300, 230),
    };
    let path = out_dir.join("measured-surfaces.png");
    write_grid(
        &path,
        &format!("Scrapes on the measured surfaces: {MATERIAL} object {OBJECT_SEED}, {SPEED_M_PER_S} m/s, {PRESSURE_N} N"),
        &panels,
        &layout,
    )?;
    Ok(path)
}
