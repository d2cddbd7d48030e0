//! Ring times read from censored recordings (docs/evaluation.md, "Censored decays";
//! [`crate::analysis::censoring`]): a recording faded, cut or capped while its sound still rang
//! says "rings at least this long". A family's log ring times are fitted as one normal
//! distribution by censored maximum likelihood (Tobit, type I right-censoring): a recording that
//! rang out contributes the density at its value, a censored one the probability of lasting
//! longer than its value, `P(X > x_c)`. That term only rises with the distribution's mean, so a
//! censored value never pulls the fit short (pooled as a measurement, it would).
//!
//! [`lengthened`] carries the fit to the recordings: each censored value becomes the fitted
//! distribution's mean beyond it, `E[X | X > x_c] = μ + σ·φ(α)/(1 − Φ(α))`, `α = (x_c − μ)/σ`,
//! which always exceeds `x_c`.

use super::damping::{ln_erfc, nelder_mead};
use crate::analysis::signal::{energy_db, two_stage_energy, Mode};
use crate::fit::recording::FileResult;

/// The 10 % quantile of the standard normal (the 90 % one is its negative).
pub const Z10: f64 = -1.281_551_565_544_600_4;
/// Smallest standard deviation a fit returns (in the values' unit; ln seconds: 1 %). Why: two
/// recordings that rang out alike would otherwise let a censored one set σ → 0.
pub const SD_FLOOR: f64 = 0.01;

/// A normal distribution fitted with censoring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CensoredNormal {
    /// Mean.
    pub mean: f64,
    /// Standard deviation (≥ [`SD_FLOOR`]).
    pub sd: f64,
    /// Values that were censored / all values.
    pub censored: usize,
    /// See [`CensoredNormal::censored`].
    pub count: usize,
}

/// `ln P(Z > z)` of a standard normal, without underflow.
fn ln_survival(z: f64) -> f64 {
    ln_erfc(z * std::f64::consts::FRAC_1_SQRT_2) - std::f64::consts::LN_2
}

impl CensoredNormal {
    /// `E[X | X > c]`: the fitted distribution's mean beyond `c`, always above `c`.
    pub fn mean_above(&self, c: f64) -> f64 {
        let a = (c - self.mean) / self.sd;
        let ln_pdf = -0.5 * a * a - 0.5 * (std::f64::consts::TAU).ln();
        let mills = (ln_pdf - ln_survival(a)).exp();
        (self.mean + self.sd * mills).max(c)
    }

    /// The `q` quantile for `q` = 0.1 or 0.9 ([`Z10`]), as the evaluation's ranges use.
    pub fn range_10_90(&self) -> (f64, f64) {
        (self.mean + Z10 * self.sd, self.mean - Z10 * self.sd)
    }
}

/// The censored maximum-likelihood normal fit of `values`, those with `censored[i]` being
/// lower bounds (right-censored); `None` with fewer than 2 distinct uncensored finite values
/// (the likelihood then does not place the distribution: censored values alone push its mean
/// without limit) or mismatched lengths. Non-finite values are ignored.
pub fn fit(values: &[f64], censored: &[bool]) -> Option<CensoredNormal> {
    if values.len() != censored.len() {
        return None;
    }
    let (exact, bounds): (Vec<(f64, bool)>, Vec<(f64, bool)>) = values
        .iter()
        .zip(censored)
        .map(|(&v, &c)| (v, c))
        .filter(|(v, _)| v.is_finite())
        .partition(|(_, c)| !c);
    let exact: Vec<f64> = exact.into_iter().map(|(v, _)| v).collect();
    let bounds: Vec<f64> = bounds.into_iter().map(|(v, _)| v).collect();
    let lo = exact.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = exact.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    if exact.len() < 2 || hi <= lo {
        return None;
    }
    let n = exact.len() as f64;
    let m0 = exact.iter().sum::<f64>() / n;
    let s0 = (exact.iter().map(|v| (v - m0).powi(2)).sum::<f64>() / n)
        .sqrt()
        .max(SD_FLOOR);
    // Parameters (μ/s0, ln σ/s0): O(1) whatever the values' scale.
    let unpack = |p: &[f64]| (m0 + s0 * p[0], (s0 * p[1].exp()).max(SD_FLOOR));
    let mut nll = |p: &[f64]| -> f64 {
        let (mu, sd) = unpack(p);
        let mut s = 0.0;
        for v in &exact {
            let z = (v - mu) / sd;
            s += sd.ln() + 0.5 * z * z;
        }
        for c in &bounds {
            s -= ln_survival((c - mu) / sd);
        }
        if s.is_finite() {
            s
        } else {
            1e300
        }
    };
    let mut p = vec![0.0, 0.0];
    for _ in 0..3 {
        p = nelder_mead(&mut nll, &p, &[0.5, 0.3], 2000, 1e-14);
    }
    let (mean, sd) = unpack(&p);
    Some(CensoredNormal {
        mean,
        sd,
        censored: bounds.len(),
        count: exact.len() + bounds.len(),
    })
}

/// `values` with each censored one replaced by the mean of the censored fit beyond it
/// ([`CensoredNormal::mean_above`]); unchanged where [`fit`] places no distribution. Every
/// returned value is at least its input: censoring only lengthens.
pub fn lengthened(values: &[f64], censored: &[bool]) -> Vec<f64> {
    let Some(f) = fit(values, censored) else {
        return values.to_vec();
    };
    values
        .iter()
        .zip(censored)
        .map(|(&v, &c)| if c && v.is_finite() { f.mean_above(v) } else { v })
        .collect()
}

/// A recording's ring time, ln seconds: over its `count` strongest `modes` by energy, the
/// energy-weighted mean of ln T60 of the single exponential carrying each mode's energy (a
/// mode's ring, [`crate::analysis::signal::Ring`], included). `NaN` without modes.
pub fn ring_time_ln(modes: &[Mode], count: usize) -> f64 {
    let mut m: Vec<&Mode> = modes.iter().collect();
    m.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
    m.truncate(count);
    let top = m.first().map_or(0.0, |x| energy_db(x));
    let (mut num, mut den) = (0.0, 0.0);
    for x in m {
        let k = x.decay_db_per_s.max(1e-3);
        let stages = x
            .ring
            .map_or(1.0, |r| two_stage_energy(r.share, k, r.decay_db_per_s.max(1e-3)));
        let w = 10f64.powf((energy_db(x) - top) / 10.0);
        num += w * (60.0 * stages / k).ln();
        den += w;
    }
    num / den
}

/// `r` with every ringing decay `factor` times slower (ring times × `factor`): its ringing
/// modes, their rings and its dense partials. The strike noise is not the ring and keeps its
/// decays.
fn slowed(r: &FileResult, factor: f64) -> FileResult {
    let slow = |m: &Mode| Mode {
        decay_db_per_s: m.decay_db_per_s / factor,
        ring: m.ring.map(|g| crate::analysis::signal::Ring {
            decay_db_per_s: g.decay_db_per_s / factor,
            ..g
        }),
        ..*m
    };
    let mut out = r.clone();
    out.ringing = r.ringing.iter().map(slow).collect();
    out.dense.partials = r.dense.partials.iter().map(slow).collect();
    out
}

/// How the pooling treated one censored recording ([`lengthen_censored`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Lengthening {
    /// The recording's file name.
    pub name: String,
    /// Its family.
    pub family: String,
    /// Its ring times' factor (≥ 1); `None` where its family's recordings place no fit
    /// ([`fit`]): kept at its bound.
    pub factor: Option<f64>,
}

/// `results` with the ring times of the censored ones ([`FileResult::censored`]) lengthened to
/// their family's censored fit: per family (`families`, in `results` order; `None`: one
/// family), a Tobit fit ([`fit`]) of the recordings' ring times ([`ring_time_ln`] of their
/// `count` strongest ringing modes), each censored recording's decays slowed by
/// `exp(E[ln T | ln T > ln T_c] − ln T_c)` ([`CensoredNormal::mean_above`]). Recordings that rang
/// out are returned unchanged; so are censored ones whose family has fewer than 2 that rang out
/// (nothing says how much longer they ring). Returns the recordings and what was done to each
/// censored one.
pub fn lengthen_censored(
    results: &[FileResult],
    families: Option<&[String]>,
    count: usize,
) -> (Vec<FileResult>, Vec<Lengthening>) {
    let family = |i: usize| families.and_then(|f| f.get(i)).map_or("", String::as_str);
    let file = |r: &FileResult| {
        std::path::Path::new(&r.name)
            .file_name()
            .map_or_else(|| r.name.clone(), |n| n.to_string_lossy().into_owned())
    };
    let mut out = results.to_vec();
    let mut done = Vec::new();
    let mut names: Vec<&str> = (0..results.len()).map(family).collect();
    names.sort_unstable();
    names.dedup();
    for fam in names {
        let idx: Vec<usize> = (0..results.len()).filter(|&i| family(i) == fam).collect();
        if !idx.iter().any(|&i| results[i].censored) {
            continue;
        }
        let t: Vec<f64> = idx
            .iter()
            .map(|&i| ring_time_ln(&results[i].ringing, count))
            .collect();
        let c: Vec<bool> = idx.iter().map(|&i| results[i].censored).collect();
        let placed = fit(&t, &c).is_some();
        let longer = lengthened(&t, &c);
        for (k, &i) in idx.iter().enumerate() {
            if !c[k] {
                continue;
            }
            let factor = (placed && t[k].is_finite()).then(|| (longer[k] - t[k]).exp());
            if let Some(f) = factor.filter(|f| *f > 1.0) {
                out[i] = slowed(&results[i], f);
            }
            done.push(Lengthening {
                name: file(&results[i]),
                family: fam.to_owned(),
                factor,
            });
        }
    }
    (out, done)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    /// `n` draws of N(`mean`, `sd`), each censored at a threshold drawn uniformly over
    /// `mean ± 2 sd`: (observed values, censored flags).
    fn censored_sample(n: usize, mean: f64, sd: f64, seed: u64) -> (Vec<f64>, Vec<bool>) {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let normal = rand_distr::Normal::new(mean, sd).unwrap();
        (0..n)
            .map(|_| {
                let x: f64 = rng.sample(normal);
                let c = mean + sd * (4.0 * rng.random::<f64>() - 2.0);
                if x > c {
                    (c, true)
                } else {
                    (x, false)
                }
            })
            .unzip()
    }

    /// Heavily censored normal samples give back their mean and SD; the same values pooled as
    /// measurements fall well short.
    #[test]
    fn recovers_mean_and_sd_of_censored_normal_data() {
        for (mean, sd, seed) in [(1.0, 0.5, 1), (-0.4, 0.2, 2), (2.3, 1.1, 3)] {
            let (v, c) = censored_sample(4000, mean, sd, seed);
            let share = c.iter().filter(|&&c| c).count() as f64 / c.len() as f64;
            assert!(share > 0.3, "censored share {share}");
            let f = fit(&v, &c).expect("fits");
            assert!((f.mean - mean).abs() < 0.05 * sd.max(1.0), "{f:?} vs {mean}");
            assert!((f.sd / sd - 1.0).abs() < 0.06, "{f:?} vs {sd}");
            assert_eq!((f.censored, f.count), ((share * 4000.0).round() as usize, 4000));
            let naive = v.iter().sum::<f64>() / v.len() as f64;
            assert!(naive < mean - 0.15 * sd, "naive {naive} vs {mean}");
        }
    }

    /// Without censoring the fit is the sample mean and (ML) SD.
    #[test]
    fn without_censoring_it_is_the_normal_fit() {
        let v = [1.0, 2.0, 4.0, 5.0];
        let f = fit(&v, &[false; 4]).unwrap();
        assert!((f.mean - 3.0).abs() < 1e-6, "{f:?}");
        assert!((f.sd - 2.5f64.sqrt()).abs() < 1e-6, "{f:?}");
    }

    /// A censored value never shortens the fit: the mean with it is at least the mean of the
    /// values that rang out alone and of all values taken as measurements, and every censored
    /// value comes back at least as long; one far below the rest moves the fit hardly at all.
    #[test]
    fn censored_values_only_lengthen() {
        let exact = [0.2, 0.5, 0.9, 1.3];
        let alone = fit(&exact, &[false; 4]).unwrap();
        for bound in [-3.0, -0.5, 0.1, 0.7, 1.2, 2.0, 6.0] {
            for k in 1..=3 {
                let mut v = exact.to_vec();
                let mut c = vec![false; 4];
                v.extend(std::iter::repeat_n(bound, k));
                c.extend(std::iter::repeat_n(true, k));
                let f = fit(&v, &c).unwrap();
                let naive = v.iter().sum::<f64>() / v.len() as f64;
                assert!(
                    f.mean >= alone.mean - 1e-6,
                    "bound {bound}×{k}: {f:?} vs {alone:?}"
                );
                assert!(
                    f.mean >= naive - 1e-6,
                    "bound {bound}×{k}: {f:?} vs naive {naive}"
                );
                let l = lengthened(&v, &c);
                for ((a, b), cen) in l.iter().zip(&v).zip(&c) {
                    assert!(a >= b, "{a} < {b}");
                    assert_eq!(a == b, !cen, "only censored values move");
                }
            }
        }
        let far = fit(&[0.2, 0.5, 0.9, 1.3, -10.0], &[false, false, false, false, true]).unwrap();
        assert!((far.mean - alone.mean).abs() < 1e-6 && (far.sd - alone.sd).abs() < 1e-6);
    }

    /// Too few values that rang out place no distribution: nothing is lengthened.
    #[test]
    fn no_fit_without_two_distinct_values_that_rang_out() {
        assert!(fit(&[1.0, 2.0, 3.0], &[true, true, false]).is_none());
        assert!(fit(&[1.0, 1.0, 3.0], &[false, false, true]).is_none());
        assert!(fit(&[1.0, 2.0], &[false]).is_none());
        assert_eq!(lengthened(&[1.0, 2.0], &[true, false]), [1.0, 2.0]);
    }

    /// A recording of `t60` seconds (two modes ringing alike), censored or not.
    fn recording(name: &str, t60: f64, censored: bool) -> FileResult {
        let mode = |freq_hz: f64| Mode {
            freq_hz,
            level_db: -20.0,
            decay_db_per_s: 60.0 / t60,
            phase: 0.0,
            attack_s: 0.0,
            ring: None,
        };
        FileResult {
            name: format!("/r/{name}.wav"),
            fs: 44_100.0,
            modes: vec![mode(300.0), mode(700.0)],
            ringing: vec![mode(300.0), mode(700.0)],
            ringing_transient: Vec::new(),
            dense_transient: None,
            attack_s: 0.0,
            transient: Vec::new(),
            distance_db: 0.0,
            note: String::new(),
            dense: Default::default(),
            censored,
        }
    }

    /// Within a family, a censored recording's ring time is lengthened beyond its bound and the
    /// others keep theirs; in a family with one recording that rings out it stays.
    #[test]
    fn pooling_lengthens_censored_recordings_of_their_family() {
        let results = [
            recording("a", 1.0, false),
            recording("b", 1.5, false),
            recording("c", 2.0, false),
            recording("d", 0.6, true),
            recording("e", 3.0, false),
            recording("f", 0.5, true),
        ];
        let families: Vec<String> = ["ride", "ride", "ride", "ride", "bell", "bell"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let t = |r: &FileResult| ring_time_ln(&r.ringing, 24).exp();
        assert!((t(&results[0]) - 1.0).abs() < 1e-9);
        let (out, done) = lengthen_censored(&results, Some(&families), 24);
        for i in [0, 1, 2, 4] {
            assert_eq!(out[i].ringing, results[i].ringing, "{i} rang out: unchanged");
        }
        assert!(t(&out[3]) > 1.0, "lengthened to {}", t(&out[3]));
        assert_eq!(out[5].ringing, results[5].ringing, "no fit for a family of one");
        assert_eq!(done.len(), 2);
        let d = done.iter().find(|l| l.name == "d.wav").unwrap();
        assert!((d.factor.unwrap() - t(&out[3]) / 0.6).abs() < 1e-9 && d.family == "ride");
        assert_eq!(done.iter().find(|l| l.name == "f.wav").unwrap().factor, None);
    }

    /// The mean beyond a bound is above it, far out by about σ²/(c − μ), and the mean itself
    /// from far below.
    #[test]
    fn mean_above_a_bound() {
        let f = CensoredNormal {
            mean: 0.0,
            sd: 1.0,
            censored: 0,
            count: 2,
        };
        assert!((f.mean_above(0.0) - (2.0 / std::f64::consts::PI).sqrt()).abs() < 1e-6);
        assert!((f.mean_above(-20.0) - 0.0).abs() < 1e-9);
        let far = f.mean_above(30.0);
        assert!(far > 30.0 && (far - 30.0 - 1.0 / 30.0).abs() < 1e-3, "{far}");
        let (lo, hi) = f.range_10_90();
        assert!((lo + 1.2816).abs() < 1e-4 && (hi - 1.2816).abs() < 1e-4);
    }
}
