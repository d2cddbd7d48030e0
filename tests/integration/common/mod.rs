//! Helpers shared by the integration tests (recordings folder, one rendered hit, a line fit,
//! onsets, a fixed-mode preset and its hits). Each test crate uses some of them, hence `allow(dead_code)`.
#![allow(dead_code)]

use std::path::PathBuf;

/// One impact at t = 0 at 1 m/s on the object `Engine::new(preset, 4, seed)` draws, rendered with
/// `settings` for `seconds` at `fs` in blocks of `block` samples: the engine and both channels.
pub fn render_one_hit(
    preset: &tactus::preset::Preset,
    seed: u64,
    settings: &tactus::engine::Settings,
    fs: f64,
    seconds: f64,
    block: usize,
) -> (tactus::engine::Engine, Vec<f32>, Vec<f32>) {
    use tactus::analysis::render::{render_hit, Hit};
    render_hit(
        preset,
        seed,
        &Hit {
            settings,
            speed_m_per_s: 1.0,
            fs,
            seconds,
            block,
        },
    )
}

/// Every recording of [`recordings`] fitted once per test run (`fit_file` with what dense fields
/// need, in parallel, in file order), shared by the tests that read those fits: fitting the
/// folder takes minutes of CPU, and fitting its cymbals twice was a third of the integration
/// tests' time. `None` when the folder is absent.
pub fn fitted_recordings() -> Option<&'static [(PathBuf, Result<tactus::fit::recording::FileResult, String>)]>
{
    use rayon::prelude::*;
    #[allow(clippy::type_complexity)]
    static FITS: std::sync::OnceLock<
        Option<Vec<(PathBuf, Result<tactus::fit::recording::FileResult, String>)>>,
    > = std::sync::OnceLock::new();
    FITS.get_or_init(|| {
        let dir = recordings()?;
        let files = tactus::fit::run::expand_inputs(&[dir])
            .expect("list recordings")
            .0;
        Some(
            files
                .par_iter()
                .map(|f| {
                    let r = tactus::fit::recording::fit_file(f, true).map_err(|e| format!("{e:#}"));
                    (f.clone(), r)
                })
                .collect(),
        )
    })
    .as_deref()
}

/// The preset `tactus fit` pools from `results` with `count` modes per object, as one family
/// (no grouping by name or manifest).
pub fn pool_one_family(
    material: &str,
    results: &[tactus::fit::recording::FileResult],
    count: usize,
) -> anyhow::Result<tactus::preset::Preset> {
    use tactus::fit::pool::{family::FamilyBy, Pooling};
    Pooling::new(material)
        .modes(count)
        .family_by(FamilyBy::None)
        .preset(results, &tactus::work::Silent)
}

/// The recordings folder: `$TACTUS_RECORDINGS`, else `../shared/recordings` beside the checkout.
/// `None` (and a "SKIPPED" line on stderr) when it does not exist. Tests that need it are also
/// marked `#[cfg_attr(tactus_no_recordings, ignore = "SKIPPED: recordings not found")]` (build.rs
/// sets that cfg when the folder is missing at build time), so the summary shows them as ignored.
pub fn recordings() -> Option<PathBuf> {
    let dir = std::env::var_os("TACTUS_RECORDINGS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/recordings"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIPPED: recordings folder {} not found (set TACTUS_RECORDINGS)",
            dir.display()
        );
        None
    }
}

/// Least-squares slope of the line through `points` (x, y); NaN with fewer than two distinct x.
pub fn line_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

/// Onset times (s): energy of the first difference (which keeps low modes, whose energy in a
/// short frame swings with their phase, from looking like onsets) in 2 ms frames every 0.25 ms;
/// an onset is a frame with 3× (4.8 dB) the energy of the quietest of the 3 ms before it, above
/// −50 dB of the loudest frame, at least `refractory_s` after the previous onset. The time is
/// the frame's start: a constant lag, which intervals cancel.
pub fn onsets(x: &[f32], sr: f64, refractory_s: f64) -> Vec<f64> {
    let hop = (sr * 0.00025) as usize;
    let win = (sr * 0.002) as usize;
    let d: Vec<f64> = x.windows(2).map(|w| (w[1] - w[0]) as f64).collect();
    let env: Vec<f64> = (0..d.len().saturating_sub(win) / hop)
        .map(|k| d[k * hop..k * hop + win].iter().map(|v| v * v).sum())
        .collect();
    let peak = env.iter().cloned().fold(0.0, f64::max);
    let back = 12;
    let mut out: Vec<f64> = Vec::new();
    for k in back..env.len() {
        let before = env[k - back..k].iter().cloned().fold(f64::INFINITY, f64::min);
        let t = (k * hop) as f64 / sr;
        if env[k] > 3.0 * before && env[k] > peak * 1e-5 && out.last().is_none_or(|&l| t - l >= refractory_s)
        {
            out.push(t);
        }
    }
    out
}

/// Onset times (s) of a break's pieces: 2 ms frames of the energy above 1 kHz (a second-order
/// Butterworth high-pass, as scipy's `butter(2, 1000, "highpass")`); an onset is a frame more
/// than 6 dB above the largest of the previous 20 ms, at least 15 ms after the previous onset,
/// frames 70 dB or more under the loudest ignored. tests/host/test_gestures.py has the same.
pub fn hf_onsets(x: &[f32], sr: f64) -> Vec<f64> {
    // RBJ high-pass at Q = 1/√2: the bilinear transform of the analogue Butterworth with the
    // cut-off pre-warped, which is what scipy designs.
    let w0 = std::f64::consts::TAU * 1000.0 / sr;
    let alpha = w0.sin() / std::f64::consts::SQRT_2;
    let a0 = 1.0 + alpha;
    let b = [
        (1.0 + w0.cos()) / 2.0 / a0,
        -(1.0 + w0.cos()) / a0,
        (1.0 + w0.cos()) / 2.0 / a0,
    ];
    let a = [-2.0 * w0.cos() / a0, (1.0 - alpha) / a0];
    let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
    let frame = (sr * 0.002).round() as usize;
    let mut energy = vec![0.0f64; x.len() / frame];
    for (k, e) in energy.iter_mut().enumerate() {
        for &v in &x[k * frame..(k + 1) * frame] {
            let v = v as f64;
            let y = b[0] * v + b[1] * x1 + b[2] * x2 - a[0] * y1 - a[1] * y2;
            (x2, x1, y2, y1) = (x1, v, y1, y);
            *e += y * y;
        }
    }
    let loudest = energy.iter().cloned().fold(0.0, f64::max);
    let back = 10; // 20 ms of 2 ms frames
    let mut out: Vec<f64> = Vec::new();
    for k in 1..energy.len() {
        let before = energy[k.saturating_sub(back)..k]
            .iter()
            .cloned()
            .fold(0.0, f64::max);
        let t = (k * frame) as f64 / sr;
        if energy[k] > 10f64.powf(0.6) * before
            && energy[k] > loudest * 1e-7
            && out.last().is_none_or(|&l| t - l >= 0.015)
        {
            out.push(t);
        }
    }
    out
}

/// A preset of the fixed `modes`, named `name`, of `material_class`, without a transient.
pub fn fixed_preset(
    name: &str,
    material_class: &str,
    modes: Vec<tactus::preset::FixedMode>,
) -> tactus::preset::Preset {
    use tactus::preset::*;
    Preset {
        format_version: FORMAT_VERSION,
        name: name.into(),
        material_class: material_class.into(),
        origin: Origin::Provisional,
        provenance: Provenance::default(),
        modes: ModeModel::Fixed { modes },
        transient: None,
        damping: None,
        contact_stiffness_n_per_m: 1e6,
        contact_exponent: tactus::engine::force::HC_DEFAULT_EXPONENT,
        families: Vec::new(),
        dense: None,
    }
}

/// The left channel an engine renders from `preset` at 48 kHz, 1 m/s impacts at the samples
/// `hits`, in blocks of 256 (transient and culling off, merging as given), and the
/// mode-samples it computed.
pub fn engine_render(
    preset: &tactus::preset::Preset,
    hits: &[usize],
    len: usize,
    merging: bool,
) -> (Vec<f64>, u64) {
    use tactus::engine::{settings::Settings, Engine, Event};
    let mut e = Engine::new(preset, 8, 1);
    e.prepare(48_000.0, 256);
    e.set_transient_enabled(false);
    e.set_culling_enabled(false);
    e.set_merging_enabled(merging);
    let s = Settings::default();
    let (mut l, mut r) = (vec![0f32; 256], vec![0f32; 256]);
    let mut out = Vec::with_capacity(len);
    for b in 0..len / 256 {
        let events: Vec<Event> = hits
            .iter()
            .filter(|&&t| t >= b * 256 && t < (b + 1) * 256)
            .map(|&t| Event::Impact {
                offset: (t - b * 256) as u32,
                velocity_m_per_s: 1.0,
                pitch_factor: 1.0,
                key: -1,
            })
            .collect();
        e.process(&s, &events, &mut l, &mut r);
        out.extend(l.iter().map(|&v| v as f64));
    }
    (out, e.take_stats().mode_samples)
}

/// The contact force of the default strike (1 m/s, default settings) on `preset`, 4096 samples
/// at 48 kHz: what an engine hit convolves a mode's response with.
pub fn default_strike_force(preset: &tactus::preset::Preset) -> Vec<f64> {
    use tactus::engine::force::{ImpactForce, ImpactParams};
    let s = tactus::engine::settings::Settings::default();
    let mut f = ImpactForce::default();
    f.start(
        &ImpactParams::new(
            s.impact.mass_kg,
            1.0,
            preset.contact_stiffness_n_per_m * s.impact.hardness,
            s.impact.contact_model,
        ),
        48_000.0,
    );
    let mut force = vec![0f32; 4096];
    f.fill(&mut force);
    force.iter().map(|&v| v as f64).collect()
}

/// `reference` scaled by the least-squares factor onto `y` (an engine's output gain and pan),
/// with the factor.
pub fn fitted_to(reference: &[f64], y: &[f64]) -> (Vec<f64>, f64) {
    let k = reference.iter().zip(y).map(|(a, b)| a * b).sum::<f64>()
        / reference.iter().map(|a| a * a).sum::<f64>();
    (reference.iter().map(|v| v * k).collect(), k)
}

/// The spectrum of `x` under a Hann window (bin `k` at `k·fs/x.len()` Hz).
pub fn hann_spectrum(x: &[f32]) -> Vec<realfft::num_complex::Complex<f64>> {
    let n = x.len();
    let fft = realfft::RealFftPlanner::<f64>::new().plan_fft_forward(n);
    let mut input: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| v as f64 * (0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n as f64).cos()))
        .collect();
    let mut spec = fft.make_output_vec();
    fft.process(&mut input, &mut spec).unwrap();
    spec
}
