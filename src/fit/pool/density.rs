//! The dense mode field of each exemplar component (docs/model.md, "Dense mode field";
//! [`crate::preset::DenseField`]): the recording's counted peaks beyond its own modes
//! ([`crate::fit::recording::dense`]) as per-band counts and level and decay laws, and the
//! calibration that scales the counts to what the engine's draws need to show them.

use super::distribution;
use crate::analysis::partials;
use crate::analysis::signal::{self, Mode};
use crate::engine::dsp::DB_PER_NEPER;
use crate::fit::recording::dense::{
    band_edges, uncovered, Candidates, DENSE_MIN_PEAK_RATIO, MIN_LEVEL_SD_DB, MIN_LN_DECAY_SD,
    MIN_PEAKS_FOR_BAND_LAWS,
};
use crate::preset::{resonator_slots, DenseBand, DenseField, Family, FixedMode, ModeModel, Origin, Preset};

/// The dense field of one exemplar component: `own` are the component's modes (levels as the
/// pooled modes', with `contact` divided out), `c` the recording's candidates. `None` when the recording's peaks are fewer
/// than [`DENSE_MIN_PEAK_RATIO`] times its modes, or none is left once those are covered.
/// Each band counts its uncovered peaks; [`calibrate_family`] then scales the counts to what
/// the engine's draws need to show the recording's peaks. With `build_ups`, each band's modes
/// swell with its [`Candidates::band_rises`], their levels raised to keep the energy they have
/// without ([`crate::fit::recording::dense::build_up_level_db`]); without, they start at their
/// onset levels.
pub fn fit_dense(
    own: &[Mode],
    c: &Candidates,
    contact: &distribution::ContactCompensation,
    build_ups: bool,
) -> Option<DenseField> {
    if own.is_empty() || (c.peaks as f64) < DENSE_MIN_PEAK_RATIO * own.len() as f64 {
        return None;
    }
    let reference = own.iter().map(|m| m.level_db).fold(f64::NEG_INFINITY, f64::max);
    let measured: Vec<(f64, f64, f64, f64)> = uncovered(c, own)
        .map(|p| {
            let p = if build_ups {
                c.swelling(p)
            } else {
                Mode { attack_s: 0.0, ..*p }
            };
            let level = p.level_db + contact.boost_db(p.freq_hz) - reference;
            (
                p.freq_hz,
                level.min(0.0),
                p.decay_db_per_s.max(1e-3).ln(),
                p.attack_s,
            )
        })
        .filter(|(_, l, d, _)| l.is_finite() && d.is_finite())
        .collect();
    if measured.is_empty() {
        return None;
    }
    let extra: Vec<(f64, f64, f64)> = measured.iter().map(|p| (p.0, p.1, p.2)).collect();
    // A band's build-up is its partials' median: half of them or more swell, or it does not.
    let rise = |rises: Vec<f64>| crate::stats::median(&rises).clamp(0.0, crate::preset::MAX_RISE_S);
    let pooled = laws(extra.iter());
    let pooled_rise = rise(measured.iter().map(|p| p.3).collect());
    let edges = band_edges();
    let bands: Vec<DenseBand> = edges
        .windows(2)
        .filter_map(|e| {
            let inside: Vec<&(f64, f64, f64)> = extra.iter().filter(|p| p.0 >= e[0] && p.0 < e[1]).collect();
            if inside.is_empty() {
                return None;
            }
            let ((level_db, level_sd_db, ln_decay, ln_decay_sd), rise_s) =
                if inside.len() >= MIN_PEAKS_FOR_BAND_LAWS {
                    let rises = measured
                        .iter()
                        .filter(|p| p.0 >= e[0] && p.0 < e[1])
                        .map(|p| p.3)
                        .collect();
                    (laws(inside.iter().copied()), rise(rises))
                } else {
                    (pooled, pooled_rise)
                };
            Some(DenseBand {
                low_hz: e[0],
                high_hz: e[1],
                modes: inside.len() as f64,
                level_db,
                level_sd_db,
                ln_decay,
                ln_decay_sd,
                rise_s,
            })
        })
        .collect();
    Some(DenseField { bands })
}

/// Rounds of [`calibrate_family`].
pub const CALIBRATION_ROUNDS: usize = 5;
/// Objects drawn per round of [`calibrate_family`]: the peak count of one draw varies by ±25 %
/// with its size shift and its Poisson counts, so a round judges their median, the statistic
/// `tactus eval` compares with the recordings' range.
pub const CALIBRATION_DRAWS: u64 = 16;
/// Draws whose median attack share [`calibrate_family`] compares with the recording's, with
/// and without the field's build-ups.
pub const ATTACK_DRAWS: u64 = 8;
/// Largest factor [`calibrate_family`] scales the counted peaks by, and the reciprocal of the
/// smallest.
pub const MAX_CALIBRATION_FACTOR: f64 = 8.0;

/// Scales every band's count of `family`'s dense field so that the objects the engine draws
/// from the family ([`ObjectSampler`]) show `c.peaks`, the recording's number of peaks, by
/// the peak count's own measure ([`partials::spectral_peaks_hz`] of the first
/// [`partials::PEAK_WINDOW_S`]), heard through the default strike's contact `contact` with the
/// family's strike noise; between 1/[`MAX_CALIBRATION_FACTOR`] and [`MAX_CALIBRATION_FACTOR`]
/// and within the engine's mode limit.
///
/// Why: a peak is counted only where it stands [`partials::PEAK_PROMINENCE_DB`] out of its
/// neighbours' skirts, so a recording's counted peaks are fewer than its partials (on synthetic
/// sounds of 152 partials: 84–88 peaks), and as many modes as peaks draw objects with fewer
/// peaks still (40–60 of 80). Why the engine's draws and its contact: a draw spreads the
/// component's modes (kernel SDs ~3 dB per level), and its dense modes are placed relative to
/// its strongest *drawn* mode, which the spread raises; and the default strike's contact takes
/// back at high frequencies the boost the fitted levels carry, so fewer high partials come
/// within [`partials::PEAK_RANGE_DB`] of the strongest (docs/model.md, "Dense mode field").
/// Why with the noise, and why a factor under 1: the strike noise of a dense component rings
/// with the wash it stands for ([`crate::fit::recording::transient::GapDecay::EarlyShare`]), and noise that
/// lasts counts as peaks too, so the field must leave room for them.
///
/// When the field builds up and `without_build_ups` (the same component fitted without them:
/// its field by [`fit_dense`], its strike noise fitted beside those partials) is given, that
/// one is calibrated too, and the family becomes whichever of the two draws default hits
/// nearer the recording's attack share `c.attack_share` in log ratio
/// ([`median_drawn_attack_share`]). Why: a swell read off a band's summed tracks is also
/// read where a strike's wash grows under the noise floor, and with build-ups everywhere the
/// Crash and Splash draws held too little of their energy in the first 10 ms (docs/model.md,
/// "Dense mode field").
pub fn calibrate_family(
    family: &mut Family,
    without_build_ups: Option<Family>,
    c: &Candidates,
    contact: &distribution::ContactCompensation,
) {
    calibrate_peaks(family, c.peaks, contact, c.fs);
    let builds_up = family.dense.as_ref().is_some_and(DenseField::builds_up);
    let Some(mut flat) = without_build_ups.filter(|_| builds_up && c.attack_share > 0.0) else {
        return;
    };
    calibrate_peaks(&mut flat, c.peaks, contact, c.fs);
    let seconds = c.n as f64 / c.fs;
    let off = |f: &Family| {
        (median_drawn_attack_share(f, contact, seconds) / c.attack_share)
            .ln()
            .abs()
    };
    let (with, without) = (off(family), off(&flat));
    if without < with || !with.is_finite() {
        *family = flat;
    }
}

/// [`calibrate_family`]'s peak count: scales the field's counts until the draws count
/// `target_peaks`.
fn calibrate_peaks(
    family: &mut Family,
    target_peaks: usize,
    contact: &distribution::ContactCompensation,
    fs: f64,
) {
    use crate::engine::limits::MAX_MODES;
    let Some(lambda) = family.dense.as_ref().map(DenseField::expected_resonators) else {
        return;
    };
    let own = match &family.modes {
        ModeModel::Distribution(d) => resonator_slots(d.count, d.partners()),
        ModeModel::Fixed { modes } => resonator_slots(modes.len(), modes.iter().map(FixedMode::has_partner)),
    };
    if !(lambda > 0.0) || target_peaks == 0 || !(fs > 0.0) {
        return;
    }
    let cap = ((MAX_MODES - own.min(MAX_MODES)) as f64 / lambda).min(MAX_CALIBRATION_FACTOR);
    let base: Vec<f64> = family
        .dense
        .iter()
        .flat_map(|d| d.bands.iter().map(|b| b.modes))
        .collect();
    let scale = |family: &mut Family, factor: f64| {
        if let Some(d) = family.dense.as_mut() {
            for (b, &m) in d.bands.iter_mut().zip(&base) {
                b.modes = m * factor;
            }
        }
    };
    let target = target_peaks as f64;
    let mut factor = 1.0f64;
    // The factor whose draws came nearest the target: the last step's is not measured, and
    // near the mode limit more modes add few peaks, so a step may overshoot.
    let mut best = (f64::INFINITY, 1.0f64);
    let lowest = 1.0 / MAX_CALIBRATION_FACTOR;
    for _ in 0..CALIBRATION_ROUNDS {
        scale(family, factor);
        let seen = median_drawn_peaks(family, contact, fs);
        if !(seen > 0.0) {
            break;
        }
        if (seen - target).abs() < best.0 {
            best = ((seen - target).abs(), factor);
        }
        // Peaks grow more slowly than modes (more of them collide), hence the exponent.
        let next = (factor * (target / seen).powf(1.5)).clamp(lowest, cap.max(lowest));
        if (next / factor - 1.0).abs() < 0.02 {
            break;
        }
        factor = next;
    }
    scale(family, best.1);
}

/// The median peak count of [`CALIBRATION_DRAWS`] objects (seeds 0, 1, …) drawn from `family`
/// alone, each synthesised from its drawn modes at `fs` (build-ups and polarities as the bank
/// plays them) with every level lowered by `contact`'s envelope at its frequency, which past
/// the capped boost the fitted levels carry takes more than they were given, and its drawn
/// strike noise played by the engine's own band bank under the same contact. 0 when the
/// family does not make a valid preset.
fn median_drawn_peaks(family: &Family, contact: &distribution::ContactCompensation, fs: f64) -> f64 {
    use crate::engine::object::{EngineRng, ObjectSampler, SampledObject};
    use rand::SeedableRng;
    let Some(preset) = family_preset(family, contact) else {
        return 0.0;
    };
    let mut sampler = ObjectSampler::new(&preset);
    let mut object = SampledObject::with_capacity();
    let mut noise_bank =
        crate::engine::transient::TransientBank::with_capacity(crate::engine::limits::MAX_BANDS);
    let len = (partials::PEAK_WINDOW_S * fs) as usize;
    let mut y = vec![0.0; len];
    let mut noise = vec![0f32; len];
    let mut counts = Vec::with_capacity(CALIBRATION_DRAWS as usize);
    for seed in 0..CALIBRATION_DRAWS {
        sampler.sample(&mut EngineRng::seed_from_u64(seed), &mut object);
        y.iter_mut().for_each(|v| *v = 0.0);
        for m in &object.modes {
            let level = m.level_db - contact.envelope_loss_db(m.freq_hz);
            let a = 10f64.powf(level / 20.0) * if m.inverted { -1.0 } else { 1.0 };
            add_mode(&mut y, fs, m.freq_hz, m.decay_db_per_s, a);
            if m.rise_s > 0.0 {
                // `e^{−σt}·(1 − e^{−t/τ})`: the same mode, less one decaying faster by 1/τ.
                let extra_db_per_s = DB_PER_NEPER / m.rise_s;
                add_mode(&mut y, fs, m.freq_hz, m.decay_db_per_s + extra_db_per_s, -a);
            }
        }
        noise.iter_mut().for_each(|v| *v = 0.0);
        noise_bank.start(&object.bands, 1.0, contact.duration_s, 1.0, 1.0, fs, seed as u32);
        noise_bank.process(&mut noise);
        for (v, n) in y.iter_mut().zip(&noise) {
            *v += f64::from(*n);
        }
        counts.push(
            partials::spectral_peaks_hz(&y, fs, partials::PEAK_RANGE_DB, partials::PEAK_PROMINENCE_DB).len()
                as f64,
        );
    }
    crate::stats::median(&counts)
}

/// `family` alone as a preset the engine draws from, struck as `contact` has it; `None` when
/// it is not valid.
fn family_preset(family: &Family, contact: &distribution::ContactCompensation) -> Option<Preset> {
    let preset = Preset {
        format_version: crate::preset::FORMAT_VERSION,
        name: family.name.clone(),
        material_class: "other".into(),
        origin: Origin::Fitted,
        provenance: Default::default(),
        modes: family.modes.clone(),
        transient: None,
        damping: family.damping,
        contact_stiffness_n_per_m: contact.stiffness_n_per_m,
        contact_exponent: contact.exponent,
        families: vec![family.clone()],
        dense: None,
    };
    preset.validate().is_ok().then_some(preset)
}

/// The median attack share ([`crate::analysis::features::attack_share`]) of [`ATTACK_DRAWS`]
/// draws of `family` alone, each one default hit rendered by the engine for `seconds` and
/// measured from its onset as `tactus eval` measures it. Why the engine and not the sampled
/// modes in closed form: the share hangs on the first 10 ms, where the contact, the build-ups
/// and the strike noise meet; the closed form missed the rendered share of a splash cymbal's
/// draws by a fifth. NaN when the family does not make a valid preset.
fn median_drawn_attack_share(
    family: &Family,
    contact: &distribution::ContactCompensation,
    seconds: f64,
) -> f64 {
    use crate::analysis::render::{render_draw, RENDER_S_RANGE};
    let Some(preset) = family_preset(family, contact) else {
        return f64::NAN;
    };
    let seconds = seconds.clamp(RENDER_S_RANGE.0, RENDER_S_RANGE.1);
    let shares: Vec<f64> = (1..=ATTACK_DRAWS)
        .map(|seed| {
            let y = signal::from_onset(&render_draw(&preset, seed, seconds));
            crate::analysis::features::attack_share(&y, crate::analysis::render::RENDER_FS)
        })
        .filter(|s| s.is_finite() && *s > 0.0)
        .collect();
    if shares.is_empty() {
        return f64::NAN;
    }
    crate::stats::median(&shares)
}

/// Adds `a·10^(−decay·t/20)·cos(2πft)` to `y` (a rotating phasor); nothing at or above 0.49·fs,
/// where the engine drops a mode.
fn add_mode(y: &mut [f64], fs: f64, freq_hz: f64, decay_db_per_s: f64, a: f64) {
    if !(freq_hz < crate::engine::limits::MAX_FREQ_FRACTION * fs) {
        return;
    }
    let w = std::f64::consts::TAU * freq_hz / fs;
    let r = 10f64.powf(-decay_db_per_s / 20.0 / fs);
    let (c, s) = (r * w.cos(), r * w.sin());
    let (mut re, mut im) = (a, 0.0);
    for v in y.iter_mut() {
        *v += re;
        (re, im) = (re * c - im * s, re * s + im * c);
    }
}

/// Mean and SD of the levels of `peaks` (frequency, level dB, ln decay), and the decay law
/// ([`energy_decay_law`]) under which modes drawn at those levels decay as the band's
/// measured partials do; SDs floored at [`MIN_LEVEL_SD_DB`] and [`MIN_LN_DECAY_SD`].
fn laws<'a>(peaks: impl Iterator<Item = &'a (f64, f64, f64)>) -> (f64, f64, f64, f64) {
    let v: Vec<&(f64, f64, f64)> = peaks.collect();
    let n = v.len().max(1) as f64;
    let mean = |f: &dyn Fn(&(f64, f64, f64)) -> f64| v.iter().map(|p| f(p)).sum::<f64>() / n;
    let (ml, md) = (mean(&|p| p.1), mean(&|p| p.2));
    let (sl, sd) = (
        mean(&|p| (p.1 - ml).powi(2)).sqrt(),
        mean(&|p| (p.2 - md).powi(2)).sqrt(),
    );
    let sd = sd.clamp(MIN_LN_DECAY_SD, crate::preset::dense::MAX_LN_DECAY_SD);
    let (md, sd) = energy_decay_law(&v, md, sd);
    (
        ml.min(0.0),
        sl.clamp(MIN_LEVEL_SD_DB, crate::preset::dense::MAX_LEVEL_SD_DB),
        md,
        sd,
    )
}

/// Points of the band's energy decay curve [`energy_decay_law`] fits, equally spaced in dB down
/// to [`ENERGY_DECAY_RANGE_DB`] (so the early decay weighs as much as the late ring).
const ENERGY_DECAY_POINTS: usize = 50;
/// How far down the band's energy decay curve [`energy_decay_law`] fits, dB (as the ring's
/// fit, [`crate::fit::recording::ring`], reads a band's Schroeder curve).
const ENERGY_DECAY_RANGE_DB: f64 = 50.0;
/// Nodes of the normal quadrature over `ln b` in [`energy_decay_law`], from −8 to +6 SD: the
/// energy of the slow side weighs `e^{−s·z}` more, so the range extends there.
const DECAY_QUADRATURE_NODES: usize = 57;

/// The `ln b` law (mean, SD) of modes whose backward-integrated energy, drawn at levels
/// independent of their decays (as [`crate::engine::dense`] draws them), falls as that of the
/// `peaks` (frequency, level dB, ln decay) measured in the band: the normalised curve
/// `Σ A²·e^{−κbt}/(κb)` (κ = ln 10/10, b in dB/s), matched in dB at
/// [`ENERGY_DECAY_POINTS`] levels down to [`ENERGY_DECAY_RANGE_DB`]. The measured `ln b` mean
/// centres the search; the measured `(mean, sd)` are returned where the curve cannot be read.
///
/// Why not the measured mean and SD: a peak's onset level is the one that gives its track's
/// energy at its decay, so of two peaks of one energy the slower starts lower, where a draw
/// takes level and decay independently and a slow decay comes at any level; the slow tail of
/// the log-normal law then holds the band's energy, which rings longer than the recording's
/// (the cymbals' components with each law: docs/fit-alternatives.md).
fn energy_decay_law(peaks: &[&(f64, f64, f64)], mean: f64, sd: f64) -> (f64, f64) {
    let kappa = std::f64::consts::LN_10 / 10.0;
    let terms: Vec<(f64, f64)> = peaks
        .iter()
        .map(|p| {
            let b = p.2.exp();
            (10f64.powf(p.1 / 10.0) / (kappa * b), kappa * b)
        })
        .filter(|(w, r)| w.is_finite() && *w > 0.0 && r.is_finite() && *r > 0.0)
        .collect();
    let total: f64 = terms.iter().map(|t| t.0).sum();
    if terms.is_empty() || !(total > 0.0 && total.is_finite()) {
        return (mean, sd);
    }
    let edc_db = |t: f64| 10.0 * (terms.iter().map(|(w, r)| w * (-r * t).exp()).sum::<f64>() / total).log10();
    // Every term falls at least as fast as the slowest, so the curve is past the range by then.
    let slowest = terms.iter().map(|t| t.1).fold(f64::INFINITY, f64::min);
    let t_max = ENERGY_DECAY_RANGE_DB / (10.0 * std::f64::consts::LOG10_E * slowest);
    if !(t_max.is_finite() && t_max > 0.0) {
        return (mean, sd);
    }
    let times: Vec<(f64, f64)> = (1..=ENERGY_DECAY_POINTS)
        .map(|j| {
            let level = -ENERGY_DECAY_RANGE_DB * j as f64 / ENERGY_DECAY_POINTS as f64;
            let (mut lo, mut hi) = (0.0, t_max);
            for _ in 0..50 {
                let mid = 0.5 * (lo + hi);
                if edc_db(mid) > level {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            (0.5 * (lo + hi), level)
        })
        .collect();
    let nodes: Vec<(f64, f64)> = (0..DECAY_QUADRATURE_NODES)
        .map(|i| {
            let z = -8.0 + 14.0 * i as f64 / (DECAY_QUADRATURE_NODES - 1) as f64;
            (z, (-0.5 * z * z).exp())
        })
        .collect();
    let misfit = |mu: f64, s: f64| -> f64 {
        // Each node a mode of decay b = e^{mu + s·z}: energy weight 1/(κb), rate κb.
        let model: Vec<(f64, f64)> = nodes
            .iter()
            .map(|&(z, w)| {
                let r = kappa * (mu + s * z).exp();
                (w / r, r)
            })
            .collect();
        let m0: f64 = model.iter().map(|m| m.0).sum();
        times
            .iter()
            .map(|&(t, level)| {
                let m = model.iter().map(|(w, r)| w * (-r * t).exp()).sum::<f64>() / m0;
                let db = 10.0 * m.max(1e-300).log10();
                (db - level).powi(2)
            })
            .sum()
    };
    let best_mean = |s: f64| signal::golden_section_min(mean - 4.0, mean + 4.0, |mu| misfit(mu, s));
    let s = signal::golden_section_min(MIN_LN_DECAY_SD, crate::preset::dense::MAX_LN_DECAY_SD, |s| {
        misfit(best_mean(s), s)
    });
    let mu = best_mean(s);
    if mu.is_finite() && s.is_finite() {
        (mu, s)
    } else {
        (mean, sd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::recording::dense::{band_build_ups, band_of, build_up_level_db};

    fn mode(freq_hz: f64, level_db: f64, decay_db_per_s: f64) -> Mode {
        Mode {
            freq_hz,
            level_db,
            decay_db_per_s,
            phase: 0.0,
            attack_s: 0.0,
            ring: None,
        }
    }

    /// Peaks covered by the component's modes are not counted again; the rest are, per band,
    /// with their levels relative to the strongest mode; a sparse recording gets no field.
    #[test]
    fn counts_uncovered_peaks_per_band() {
        let own = vec![mode(440.0, -10.0, 20.0), mode(1000.0, -20.0, 20.0)];
        let mut partials = vec![mode(441.0, -12.0, 20.0)];
        partials.extend((0..10).map(|i| mode(2000.0 + 30.0 * i as f64, -30.0, 40.0)));
        let c = Candidates {
            peaks: 11,
            partials,
            fs: 48_000.0,
            n: 48_000,
            band_rises: Vec::new(),
            attack_share: 0.0,
        };
        let contact = distribution::ContactCompensation::default_strike(
            1e12,
            crate::engine::force::HC_DEFAULT_EXPONENT,
        );
        let f = fit_dense(&own, &c, &contact, true).expect("dense");
        // 12 partials, 11 peaks counted: at least the 10 uncovered peaks' worth of modes.
        assert!(f.expected_modes() >= 10.0, "{}", f.expected_modes());
        assert_eq!(f.bands.len(), 2, "{f:?}");
        for b in &f.bands {
            assert!(
                // The contact (1e12 N/m) divides out < 1e-6 dB at these frequencies; one decay's
                // law at the smallest spread holds its energy curve with a mean 1–2 % faster.
                (b.level_db + 20.0).abs() < 1e-6 && (b.ln_decay - 40f64.ln()).abs() < 0.02,
                "{b:?}"
            );
            assert_eq!(b.level_sd_db, MIN_LEVEL_SD_DB);
        }
        // With its bands' build-ups the field swells, each level raised to keep its energy;
        // without, it is the field above.
        let swelling = Candidates {
            band_rises: vec![0.05; band_edges().len() - 1],
            ..c.clone()
        };
        let up = fit_dense(&own, &swelling, &contact, true).expect("dense");
        let raise = build_up_level_db(40.0, 0.05);
        assert!(raise > 1.0, "{raise}");
        for (b, flat) in up.bands.iter().zip(&f.bands) {
            assert_eq!(b.rise_s, 0.05);
            assert!((b.level_db - (flat.level_db + raise)).abs() < 1e-6, "{b:?}");
        }
        assert_eq!(fit_dense(&own, &swelling, &contact, false), Some(f.clone()));
        let sparse = Candidates { peaks: 3, ..c };
        assert!(fit_dense(&own, &sparse, &contact, true).is_none());
    }

    /// The level [`build_up_level_db`] adds gives a mode that builds up the energy it has
    /// without the build-up (trapezoidal sums of both envelopes, squared).
    #[test]
    fn build_up_level_keeps_the_energy() {
        for (decay, rise) in [(5.0, 0.04), (60.0, 0.01), (400.0, 0.064)] {
            let sigma = decay / DB_PER_NEPER;
            let dt = 1e-5;
            let energy = |a: f64, tau: f64| -> f64 {
                (0..(30.0 / sigma / dt) as usize)
                    .map(|i| {
                        let t = i as f64 * dt;
                        let up = if tau > 0.0 { 1.0 - (-t / tau).exp() } else { 1.0 };
                        (a * up * (-sigma * t).exp()).powi(2) * dt
                    })
                    .sum()
            };
            let gain = 10f64.powf(build_up_level_db(decay, rise) / 20.0);
            let (free, built) = (energy(1.0, 0.0), energy(gain, rise));
            assert!(
                (built / free - 1.0).abs() < 1e-3,
                "{decay} dB/s, τ {rise}: {built} vs {free}"
            );
        }
        assert_eq!(build_up_level_db(20.0, 0.0), 0.0);
        assert_eq!(build_up_level_db(0.0, 0.05), 0.0);
    }

    /// A band whose partials swell gets their build-up back from the sum of their tracks; a
    /// band whose partials start at full level gets none.
    #[test]
    fn reads_a_band_build_up_from_its_partials_tracks() {
        let fs = 48_000.0;
        let (tau, decay) = (0.04, 20.0);
        let sigma = decay / DB_PER_NEPER;
        let swelling: Vec<f64> = (0..6).map(|i| 2100.0 + 60.0 * i as f64).collect();
        let flat: Vec<f64> = (0..6).map(|i| 5200.0 + 60.0 * i as f64).collect();
        let y: Vec<f64> = (0..(1.5 * fs) as usize)
            .map(|i| {
                let t = i as f64 / fs;
                let decayed = (-sigma * t).exp();
                let up = 1.0 - (-t / tau).exp();
                let tone = |f: &f64| (std::f64::consts::TAU * f * t + f / 7.0).sin();
                decayed * (up * swelling.iter().map(tone).sum::<f64>() + flat.iter().map(tone).sum::<f64>())
            })
            .collect();
        let partials: Vec<Mode> = swelling
            .iter()
            .chain(&flat)
            .map(|&f| mode(f, 0.0, decay))
            .collect();
        let rises = band_build_ups(&partials, &y, fs);
        let (up, level) = (rises[band_of(2100.0)], rises[band_of(5200.0)]);
        assert!((up / tau - 1.0).abs() < 0.25, "read τ {up} s for {tau} s");
        assert_eq!(level, 0.0);
        assert!(rises
            .iter()
            .enumerate()
            .all(|(b, &r)| r == 0.0 || b == band_of(2100.0)));
    }

    #[test]
    fn decay_law_holds_the_bands_energy_decay() {
        let kappa = std::f64::consts::LN_10 / 10.0;
        // One decay: its own law at the smallest spread, whose slow side the mean offsets.
        let one: Vec<(f64, f64, f64)> = (0..8)
            .map(|i| (1000.0 + 10.0 * i as f64, -20.0, 20f64.ln()))
            .collect();
        let (mu, sd) = energy_decay_law(&one.iter().collect::<Vec<_>>(), 20f64.ln(), 0.3);
        assert!(
            (mu - 20f64.ln()).abs() < 0.02 && sd < MIN_LN_DECAY_SD + 0.01,
            "{mu} {sd}"
        );
        // Decays spread ±2 SD of 0.5 in ln, every peak of the same energy (the slower starting
        // lower, as onset levels from track energies are): drawn independently of the levels,
        // the measured law's slow tail would hold the energy, so the fitted law is narrower.
        let spread: Vec<(f64, f64, f64)> = (0..21)
            .map(|i| {
                let ln_b = 20f64.ln() + 0.5 * (-2.0 + 0.2 * i as f64);
                (
                    1000.0 + 10.0 * i as f64,
                    10.0 * (kappa * ln_b.exp()).log10(),
                    ln_b,
                )
            })
            .collect();
        let peaks: Vec<_> = spread.iter().collect();
        let measured_sd = (spread.iter().map(|p| (p.2 - 20f64.ln()).powi(2)).sum::<f64>() / 21.0).sqrt();
        let (mu, sd) = energy_decay_law(&peaks, 20f64.ln(), measured_sd);
        assert!(sd < 0.8 * measured_sd, "{sd} against {measured_sd}");
        assert!(mu.is_finite() && (mu - 20f64.ln()).abs() < 0.5, "{mu}");
    }
}
