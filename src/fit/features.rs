//! Material features of one impact sound, used to check that fitted presets keep materials
//! apart (issue #4: "closer to the wood recordings than to the metal ones").
//!
//! Both features are computed from *audio* with the same pipeline for recordings and for
//! engine renders:
//!
//! - **tan φ** (Giordano & Avanzini 2014, internal friction / loss angle; MODEL.md §4): in the
//!   internal-friction model every mode's amplitude decays as `exp(−α t)` with
//!   `α = π·f·tan φ` (1/s), i.e. the decay rate grows linearly with frequency, and tan φ is that
//!   slope divided by π. Per mode `m` from [`extract::extract`] followed by
//!   [`extract::consolidate`] (the [`FEATURE_MODES`] strongest by energy, only those within
//!   [`FEATURE_RANGE_DB`] of the strongest energy):
//!   `α_m = b_m / (20·log10 e)` with `b_m` in dB/s, and the sound's value is the least-squares
//!   fit of `ln α_m = ln(π tan φ) + ln f_m` with the slope fixed at 1, i.e.
//!   `ln tan φ = mean_m(ln α_m − ln(π f_m))` (a geometric mean of the per-mode loss angles, which
//!   keeps one fast high mode from dominating as it would in a linear fit).
//!   Feature: `log10 tan φ`.
//! - **Spectral centroid** `Σ f·|X(f)| / Σ |X(f)|` of the magnitude spectrum of the whole signal
//!   from its onset (rectangular window, zero-padded FFT), restricted to
//!   [`CENTROID_BAND_HZ`] so recordings at 20 kHz and renders at 44.1 kHz are measured over the
//!   same band. Feature: `log2 centroid` (Hz).
//!
//! The distance between two sounds is the Euclidean distance of the two feature vectors after
//! dividing each feature by a scale (the pooled standard deviation over the reference
//! recordings, see [`pooled_std`]).

use crate::fit::extract;
use realfft::RealFftPlanner;

/// Modes used for tan φ (Traer et al. use the 15 strongest).
pub const FEATURE_MODES: usize = 15;
/// Modes more than this many dB below the strongest are ignored for tan φ.
pub const FEATURE_RANGE_DB: f64 = 40.0;
/// Frequency band of the spectral centroid, Hz (upper end below the lowest recording Nyquist,
/// 10 kHz).
pub const CENTROID_BAND_HZ: (f64, f64) = (50.0, 9_000.0);

/// Features of one sound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Features {
    /// Loss factor tan φ (dimensionless).
    pub tan_phi: f64,
    /// Spectral centroid, Hz.
    pub centroid_hz: f64,
    /// Modes used for tan φ.
    pub modes_used: usize,
}

impl Features {
    /// `[log10 tan φ, log2 centroid]`.
    pub fn vector(&self) -> [f64; 2] {
        [self.tan_phi.log10(), self.centroid_hz.log2()]
    }
}

/// Modes extracted per sound before consolidation (copies of one mode are merged, so more
/// than [`FEATURE_MODES`] are needed).
pub const EXTRACT_MODES: usize = 30;

/// Features of `x` (mono, full scale) at `fs`, tan φ from the modes extracted from the audio
/// (`extract` → `consolidate`); `None` if fewer than 2 usable modes are found.
pub fn features(x: &[f64], fs: f64) -> Option<Features> {
    let ex = extract::extract(x, fs, EXTRACT_MODES);
    let modes = extract::consolidate(&ex.modes, extract::CONSOLIDATE_REL);
    let y: Vec<f64> = x[ex.onset..].iter().map(|v| v - ex.dc).collect();
    features_with_modes(&y, fs, &modes)
}

/// Features with tan φ from a given mode list (e.g. the modes of a sampled object) and the
/// centroid from the audio `y` (taken from its onset).
pub fn features_with_modes(y: &[f64], fs: f64, modes: &[extract::Mode]) -> Option<Features> {
    let (tan_phi, modes_used) = tan_phi(modes)?;
    let centroid_hz = spectral_centroid(y, fs)?;
    Some(Features {
        tan_phi,
        centroid_hz,
        modes_used,
    })
}

/// tan φ of a mode list: the [`FEATURE_MODES`] strongest by energy
/// ([`extract::energy_db`]) within [`FEATURE_RANGE_DB`] of the strongest energy, fitted as in
/// the module docs. Returns (tan φ, modes used); `None` with fewer than 2 modes.
pub fn tan_phi(modes: &[extract::Mode]) -> Option<(f64, usize)> {
    let mut m: Vec<&extract::Mode> = modes
        .iter()
        .filter(|m| m.decay_db_per_s > 0.0 && m.freq_hz > 0.0 && m.level_db.is_finite())
        .collect();
    m.sort_by(|a, b| extract::energy_db(b).total_cmp(&extract::energy_db(a)));
    let top = extract::energy_db(m.first()?);
    let db_per_neper = 20.0 * std::f64::consts::LOG10_E;
    let ln_tan: Vec<f64> = m
        .iter()
        .take(FEATURE_MODES)
        .filter(|m| extract::energy_db(m) >= top - FEATURE_RANGE_DB)
        .map(|m| (m.decay_db_per_s / db_per_neper).ln() - (std::f64::consts::PI * m.freq_hz).ln())
        .collect();
    if ln_tan.len() < 2 {
        return None;
    }
    Some((
        (ln_tan.iter().sum::<f64>() / ln_tan.len() as f64).exp(),
        ln_tan.len(),
    ))
}

/// Magnitude-spectrum centroid of `y` over [`CENTROID_BAND_HZ`] (clipped to 0.49·fs), Hz.
pub fn spectral_centroid(y: &[f64], fs: f64) -> Option<f64> {
    let nfft = (2 * y.len()).next_power_of_two().max(64);
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let mut buf = vec![0.0; nfft];
    buf[..y.len()].copy_from_slice(y);
    let mut spec = fft.make_output_vec();
    fft.process(&mut buf, &mut spec).ok()?;
    let bin = fs / nfft as f64;
    let (lo, hi) = (CENTROID_BAND_HZ.0, CENTROID_BAND_HZ.1.min(0.49 * fs));
    let (mut num, mut den) = (0.0, 0.0);
    for (k, c) in spec.iter().enumerate() {
        let f = k as f64 * bin;
        if f >= lo && f <= hi {
            let m = c.norm();
            num += f * m;
            den += m;
        }
    }
    (den > 0.0).then(|| num / den)
}

/// Per-feature standard deviation pooled over groups (within-group variance, each group's
/// deviations from its own mean, divided by `N − groups`). Groups with < 2 members add nothing.
pub fn pooled_std(groups: &[&[[f64; 2]]]) -> [f64; 2] {
    let mut out = [0.0; 2];
    for (j, o) in out.iter_mut().enumerate() {
        let (mut ss, mut dof) = (0.0, 0usize);
        for g in groups {
            if g.len() < 2 {
                continue;
            }
            let m = g.iter().map(|v| v[j]).sum::<f64>() / g.len() as f64;
            ss += g.iter().map(|v| (v[j] - m).powi(2)).sum::<f64>();
            dof += g.len() - 1;
        }
        *o = if dof > 0 { (ss / dof as f64).sqrt() } else { 1.0 };
    }
    out
}

/// Normalised Euclidean distance `sqrt(Σ_j ((a_j − b_j)/scale_j)²)`.
pub fn distance(a: &[f64; 2], b: &[f64; 2], scale: &[f64; 2]) -> f64 {
    (0..2)
        .map(|j| ((a[j] - b[j]) / scale[j]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Mean normalised distance from `a` to every member of `group`.
pub fn mean_distance(a: &[f64; 2], group: &[[f64; 2]], scale: &[f64; 2]) -> f64 {
    group.iter().map(|b| distance(a, b, scale)).sum::<f64>() / group.len().max(1) as f64
}
