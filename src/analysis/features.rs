//! Perceptual features of one impact sound, computed by ONE function ([`sound_features`]) for
//! recordings and engine renders alike, so that `tactus eval` compares like with like.
//! docs/evaluation.md gives the definitions with their reasons; in short, from the signal `y`
//! (the input from its onset, DC removed, [`signal::onset_and_dc`]):
//!
//! - **centroid** `Σ f·|Y(f)| / Σ |Y(f)|` over [`CENTROID_BAND_HZ`] (whole signal, rectangular
//!   window, zero-padded FFT), Hz;
//! - **partials**: the spectral peaks counted by the peak count (below), each followed in time
//!   by a short-time DTFT at its frequency over the first [`partials::MODE_SPAN_S`]; a partial's decay
//!   `b_m` (dB/s) is the line fit of its dB track from the track's maximum to its noise floor
//!   or a fade, its energy the track's ([`partials::partials`]);
//! - **tan φ** (Giordano & Avanzini's loss factor; docs/model.md §4): with the amplitude decay rate
//!   `α_m = b_m / (20·log10 e)` (1/s) of partial `m`, `ln tan φ = mean_m(ln α_m − ln(π f_m))`
//!   over the [`FEATURE_MODES`] strongest partials by energy within [`FEATURE_RANGE_DB`] of the
//!   strongest (least-squares fit of `ln α = ln(π tan φ) + ln f` with slope fixed at 1);
//! - **decay slope**: the free least-squares slope of `ln α_m` vs `ln f_m` over the same partials
//!   (0: all partials ring equally long; 1: internal friction, decay ∝ f; Sterling's Rayleigh law
//!   gives 0 at low and 2 at high frequency);
//! - **T60** of the strongest partials: median over the [`T60_PARTIALS`] strongest partials'
//!   bands of `60 / b` (s), `b` the decay of the band's backward-integrated (Schroeder) energy
//!   ([`partials::band_decays`]: a band holds a beating cluster whole);
//! - **attack share**: energy of `y` in its first [`ATTACK_WINDOW_S`] over its total energy;
//! - **EDT** (early decay time, ISO 3382): median over the same bands of −60 dB over the slope
//!   of the band's Schroeder curve from the onset to −10 dB (least-squares line), s;
//! - **peak count**: local maxima of the Blackman–Harris magnitude spectrum of the first
//!   [`partials::PEAK_WINDOW_S`] within [`CENTROID_BAND_HZ`], at most [`partials::PEAK_RANGE_DB`]
//!   below the highest and standing [`partials::PEAK_PROMINENCE_DB`] above the valleys that separate them from any higher
//!   peak (topographic prominence).
//!
//! The partials are read off the signal, not off `tactus fit`'s extracted components: see
//! [`partials::partials`] for why.

use crate::analysis::audio;
use crate::analysis::labels::{Labelled, Skipped};
use crate::analysis::partials::{self, peaks_and_partials};
use crate::analysis::signal::energy_db;
use crate::analysis::signal::{self, Mode};
use crate::engine::dsp::DB_PER_NEPER;
use crate::stats::median;
use crate::work::Observer;
use rayon::prelude::*;
use serde::Serialize;

/// Partials used for tan φ and the decay slope (Traer et al. use the 15 strongest modes).
pub const FEATURE_MODES: usize = 15;
/// Partials more than this many dB below the strongest (by energy) are ignored for tan φ and slope.
pub const FEATURE_RANGE_DB: f64 = 40.0;
/// Band of the spectral centroid (the fit's: [`partials::CENTROID_BAND_HZ`]).
pub const CENTROID_BAND_HZ: (f64, f64) = partials::CENTROID_BAND_HZ;
/// Partials whose bands' median T60 and EDT are the T60 and EDT features.
pub const T60_PARTIALS: usize = 5;
/// Window of the attack share, s: a stick's contact and the strike noise are over by then,
/// while a struck object's ringing has barely begun.
pub const ATTACK_WINDOW_S: f64 = 0.010;
/// Names of the features in [`SoundFeatures::values`] order (also the JSON keys).
pub const FEATURE_NAMES: [&str; 7] = [
    "centroid_hz",
    "tan_phi",
    "t60_s",
    "decay_slope",
    "attack_share",
    "edt_s",
    "peak_count",
];
/// Number of features.
pub const N_FEATURES: usize = FEATURE_NAMES.len();

/// The features of one sound.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SoundFeatures {
    /// Spectral centroid over [`CENTROID_BAND_HZ`], Hz.
    pub centroid_hz: f64,
    /// Loss factor tan φ (dimensionless).
    pub tan_phi: f64,
    /// Median T60 of the strongest partials' bands, s.
    pub t60_s: f64,
    /// Slope of ln(decay rate) vs ln(frequency).
    pub decay_slope: f64,
    /// Share of the energy in the first [`ATTACK_WINDOW_S`] (0…1).
    pub attack_share: f64,
    /// Median early decay time of the strongest partials' bands, s.
    pub edt_s: f64,
    /// Spectral peaks counted.
    pub peak_count: f64,
}

impl SoundFeatures {
    /// The features in [`FEATURE_NAMES`] order, in their own units.
    pub fn values(&self) -> [f64; N_FEATURES] {
        [
            self.centroid_hz,
            self.tan_phi,
            self.t60_s,
            self.decay_slope,
            self.attack_share,
            self.edt_s,
            self.peak_count,
        ]
    }

    /// The coordinates the classifier standardises: the logarithm of the features that span
    /// decades (centroid, tan φ, T60, EDT, and 1 + peak count: 2 to 230 peaks are measured; their
    /// spread is multiplicative), the slope and attack share as they are.
    pub fn vector(&self) -> [f64; N_FEATURES] {
        [
            self.centroid_hz.log2(),
            self.tan_phi.log10(),
            self.t60_s.log10(),
            self.decay_slope,
            self.attack_share,
            self.edt_s.log10(),
            (1.0 + self.peak_count).log10(),
        ]
    }
}

/// The features of `x` (mono, any scale) at `fs`. Errors say in words why a sound has none
/// (too few decaying partials, silence).
pub fn sound_features(x: &[f64], fs: f64) -> Result<SoundFeatures, String> {
    if x.is_empty() || !(fs > 0.0) {
        return Err("empty signal".into());
    }
    let y = signal::from_onset(x);
    if y.iter().all(|v| *v == 0.0) {
        return Err("silent".into());
    }
    let (peaks_hz, modes) = peaks_and_partials(&y, fs);
    let strongest = strongest_modes(&modes);
    let (tan_phi, _) = tan_phi(&modes).ok_or("fewer than 2 decaying partials found")?;
    let decay_slope = decay_slope(&strongest).ok_or("partials at fewer than 2 distinct frequencies")?;
    let bands = partials::band_decays(
        &y,
        fs,
        &partials::partial_peaks_hz(&y, fs, &peaks_hz),
        T60_PARTIALS,
    );
    if bands.is_empty() {
        return Err("no partial's band decays".into());
    }
    let t60: Vec<f64> = bands.iter().map(|b| 60.0 / b.decay_db_per_s).collect();
    let edt: Vec<f64> = bands.iter().map(|b| b.edt_s).collect();
    let centroid_hz = partials::spectral_centroid(&y, fs).ok_or("no energy in the centroid band")?;
    Ok(SoundFeatures {
        centroid_hz,
        tan_phi,
        t60_s: median(&t60),
        decay_slope,
        attack_share: attack_share(&y, fs),
        edt_s: median(&edt),
        peak_count: peaks_hz.len() as f64,
    })
}

/// The decaying modes, strongest by energy ([`energy_db`]) first, limited to the
/// [`FEATURE_MODES`] strongest within [`FEATURE_RANGE_DB`] of the strongest.
fn strongest_modes(modes: &[Mode]) -> Vec<Mode> {
    let mut m: Vec<Mode> = modes
        .iter()
        .filter(|m| m.decay_db_per_s > 0.0 && m.freq_hz > 0.0 && m.level_db.is_finite())
        .copied()
        .collect();
    m.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
    let Some(top) = m.first().map(energy_db) else {
        return m;
    };
    // The two strongest stay whatever their distance (a nearly pure tone's second partial),
    // so every sound with two decaying partials has a slope.
    m.into_iter()
        .take(FEATURE_MODES)
        .enumerate()
        .filter(|(i, m)| *i < 2 || energy_db(m) >= top - FEATURE_RANGE_DB)
        .map(|(_, m)| m)
        .collect()
}

/// Amplitude decay rate α (1/s) of a mode.
fn alpha(m: &Mode) -> f64 {
    m.decay_db_per_s / DB_PER_NEPER
}

/// tan φ of a mode list (see the module docs). Returns (tan φ, modes used); `None` with fewer
/// than 2 modes.
pub fn tan_phi(modes: &[Mode]) -> Option<(f64, usize)> {
    let ln_tan: Vec<f64> = strongest_modes(modes)
        .iter()
        .map(|m| alpha(m).ln() - (std::f64::consts::PI * m.freq_hz).ln())
        .collect();
    if ln_tan.len() < 2 {
        return None;
    }
    Some((
        (ln_tan.iter().sum::<f64>() / ln_tan.len() as f64).exp(),
        ln_tan.len(),
    ))
}

/// Least-squares slope of ln α vs ln f; `None` without two distinct frequencies.
fn decay_slope(modes: &[Mode]) -> Option<f64> {
    ls_slope(modes.iter().map(|m| (m.freq_hz.ln(), alpha(m).ln())))
}

/// Least-squares slope of y against x over `points`; `None` without two distinct x.
fn ls_slope(points: impl Iterator<Item = (f64, f64)>) -> Option<f64> {
    let pts: Vec<(f64, f64)> = points.collect();
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (pts.len() >= 2 && sxx > 1e-12).then(|| sxy / sxx)
}

/// Energy in the first [`ATTACK_WINDOW_S`] of `y` over its total energy.
pub fn attack_share(y: &[f64], fs: f64) -> f64 {
    let k = ((ATTACK_WINDOW_S * fs).round() as usize).min(y.len());
    let total: f64 = y.iter().map(|v| v * v).sum();
    if total > 0.0 {
        y[..k].iter().map(|v| v * v).sum::<f64>() / total
    } else {
        0.0
    }
}

/// A measured recording.
#[derive(Debug, Clone, Serialize)]
pub struct Measured {
    /// Labels.
    #[serde(flatten)]
    pub label: Labelled,
    /// Its features.
    pub features: SoundFeatures,
    /// Its length, s: draws judged against it are rendered as long ([`crate::analysis::render`]).
    pub duration_s: f64,
    /// The signal ends before the sound has decayed ([`crate::analysis::censoring::from_signal`]):
    /// its decay features are lower bounds, where no manifest says otherwise.
    pub ends_ringing: bool,
}

/// Measures every labelled recording (in parallel, order kept); unreadable files and files
/// without features are skipped with the reason. `observer` hears each file measured.
pub fn measure_recordings(files: &[Labelled], observer: &dyn Observer) -> (Vec<Measured>, Vec<Skipped>) {
    let results: Vec<Result<Measured, Skipped>> = files
        .par_iter()
        .map(|l| {
            let r = audio::read_recording(&l.path)
                .map_err(|e| format!("{e:#}").replace(&format!("{}: ", l.path.display()), ""))
                .and_then(|rec| {
                    let duration_s = rec.samples.len() as f64 / rec.sample_rate;
                    let ends_ringing = crate::analysis::censoring::from_signal(&rec.samples, rec.sample_rate);
                    sound_features(&rec.samples, rec.sample_rate)
                        .map(|f| (f, duration_s, ends_ringing))
                        .map_err(|e| format!("no features: {e}"))
                });
            observer.advanced("recording", 1);
            r.map(|(features, duration_s, ends_ringing)| Measured {
                label: l.clone(),
                features,
                duration_s,
                ends_ringing,
            })
            .map_err(|reason| Skipped {
                name: l.name.clone(),
                reason,
            })
        })
        .collect();
    let (mut ok, mut bad) = (Vec::new(), Vec::new());
    for r in results {
        match r {
            Ok(m) => ok.push(m),
            Err(s) => bad.push(s),
        }
    }
    (ok, bad)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sum of decaying partials starting at sample 0.
    fn partials(fs: f64, secs: f64, p: &[(f64, f64, f64)]) -> Vec<f64> {
        (0..(secs * fs) as usize)
            .map(|i| {
                let t = i as f64 / fs;
                p.iter()
                    .map(|&(f, a, db_s)| {
                        a * 10f64.powf(-db_s * t / 20.0) * (std::f64::consts::TAU * f * t).sin()
                    })
                    .sum()
            })
            .collect()
    }

    #[test]
    fn t60_and_edt_of_exponential_decays_are_their_rings() {
        let fs = 44_100.0;
        // 60 dB/s: T60 = 1 s, in every band.
        let y = partials(fs, 3.0, &[(440.0, 1.0, 60.0), (1_330.0, 0.5, 60.0)]);
        let f = sound_features(&y, fs).unwrap();
        assert!((f.t60_s - 1.0).abs() < 0.05, "{f:?}");
        assert!((f.edt_s - 1.0).abs() < 0.1, "{f:?}");
        // A click in the first 10 ms on top of it raises the attack share; read per band, the
        // partials' early decay is theirs, not the click's.
        let mut z = y.clone();
        for (i, v) in z.iter_mut().take(441).enumerate() {
            *v += 8.0 * (1.0 - i as f64 / 441.0) * if i % 2 == 0 { 1.0 } else { -1.0 };
        }
        let g = sound_features(&z, fs).unwrap();
        assert!(attack_share(&z, fs) > 5.0 * attack_share(&y, fs));
        assert!((g.edt_s / f.edt_s - 1.0).abs() < 0.1, "{g:?} vs {f:?}");
    }

    #[test]
    fn features_follow_the_partials() {
        let fs = 44_100.0;
        // Decay rate ∝ f: slope 1; three partials well apart.
        let y = partials(
            fs,
            2.0,
            &[(300.0, 1.0, 30.0), (900.0, 0.5, 90.0), (2_700.0, 0.25, 270.0)],
        );
        let f = sound_features(&y, fs).unwrap();
        assert!((f.decay_slope - 1.0).abs() < 0.1, "{f:?}");
        assert_eq!(f.peak_count, 3.0, "{f:?}");
        // tan φ = α / (π f) = (30 / 8.686) / (π 300).
        let want = 30.0 / DB_PER_NEPER / (std::f64::consts::PI * 300.0);
        assert!((f.tan_phi / want - 1.0).abs() < 0.1, "{f:?} vs {want}");
        // Median T60 of the strongest three: 60/90 s.
        assert!((f.t60_s - 60.0 / 90.0).abs() < 0.05, "{f:?}");
        assert!(f.centroid_hz > 300.0 && f.centroid_hz < 2_700.0, "{f:?}");
    }

    #[test]
    fn t60_is_the_ring_of_a_swelling_partial_not_the_strike() {
        let fs = 44_100.0;
        // Two partials that swell over 30 ms and ring with T60 1.2 s and 0.8 s, under a knock
        // of loud components 30 Hz beside them dying at 2000 dB/s: the kind of sound the
        // extractor splits into large, fast, cancelling copies.
        let mut y = partials(fs, 2.0, &[(523.0, 1.0, 50.0), (1_570.0, 0.6, 75.0)]);
        for (i, v) in y.iter_mut().enumerate() {
            *v *= 1.0 - (-(i as f64) / fs / 0.03).exp();
        }
        let strike = [(553.0, 3.0, 2_000.0), (1_540.0, 3.0, 2_000.0)];
        for (v, s) in y.iter_mut().zip(partials(fs, 2.0, &strike)) {
            *v += s;
        }
        let f = sound_features(&y, fs).unwrap();
        assert!((f.t60_s - 1.0).abs() < 0.25, "{f:?}");
        assert!(f.decay_slope > 0.0, "{f:?}");
    }

    #[test]
    fn silence_has_no_features() {
        assert!(sound_features(&[0.0; 4410], 44_100.0).is_err());
        assert!(sound_features(&[], 44_100.0).is_err());
    }
}
