//! Objects sampled from a material's mode distribution (docs/model.md §3, Traer eq. 4 and §2.1):
//! a Gaussian draw via a precomputed Cholesky factor, rejection until the mean mode spacing is
//! within tolerance of the material's, and per-hit onset-power perturbation for re-hits.
//!
//! Everything that allocates happens in [`ObjectSampler::new`] and [`SampledObject::with_capacity`];
//! sampling and perturbation write into preallocated buffers and can run on the audio thread.

use super::dsp::linalg::cholesky;
use crate::preset::{
    DampingModel, DecayCoordinates, ModeDistribution, ModeModel, ModeRing, Preset, SizeClass,
    TransientDistribution, DECAY_RANGE_DB_PER_S,
};
use rand::rngs::Xoshiro256PlusPlus;
use rand::RngExt;
use rand_distr::StandardNormal;

/// Deterministic, portable RNG used everywhere in the engine.
pub type EngineRng = Xoshiro256PlusPlus;

/// Rejection-sampling attempts before the closest draw so far is accepted. Traer's tolerance of
/// 10 % accepts a typical draw within a few tries; the cap bounds the audio-thread cost.
pub const MAX_REJECTION_TRIES: usize = 64;

use super::limits::{MAX_BANDS, MAX_MODES};

/// One sampled mode at `size = 1`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ObjectMode {
    /// Frequency in Hz.
    pub freq_hz: f64,
    /// Onset level in dB.
    pub level_db: f64,
    /// Decay in dB/s.
    pub decay_db_per_s: f64,
    /// Build-up time τ in s (0: none), from the preset's `rise_s`.
    pub rise_s: f64,
    /// The ring after the knock (share 0: none), from the preset's `ring`/`rings`.
    pub ring: ModeRing,
    /// The mode sounds with inverted polarity (a negative gain): a dense field's modes draw it
    /// ([`super::dense::add_dense_modes`]), every other mode starts positive.
    pub inverted: bool,
}

/// One sampled noise band of the transient.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ObjectBand {
    /// Centre frequency in Hz (ERB-spaced).
    pub centre_hz: f64,
    /// Onset level in dB.
    pub level_db: f64,
    /// Decay in dB/s.
    pub decay_db_per_s: f64,
}

/// A concrete object: its modes and transient bands, in preallocated storage.
#[derive(Debug, Clone)]
pub struct SampledObject {
    /// Modes (sorted by frequency).
    pub modes: Vec<ObjectMode>,
    /// Transient bands.
    pub bands: Vec<ObjectBand>,
    /// The object size at which the modes sound at their frequencies here: 1, or the
    /// reference of the size class it was drawn from ([`crate::preset::SizeClass`]).
    pub reference_size: f64,
}

impl SampledObject {
    /// Empty object with room for `MAX_MODES` modes and `MAX_BANDS` bands.
    pub fn with_capacity() -> Self {
        Self {
            modes: Vec::with_capacity(MAX_MODES),
            bands: Vec::with_capacity(MAX_BANDS),
            reference_size: 1.0,
        }
    }

    /// Mean spacing between adjacent sorted mode frequencies, in octaves.
    pub fn mean_spacing_octaves(&self) -> f64 {
        spacing_octaves(self.modes.iter().map(|m| m.freq_hz))
    }

    /// Copies `other` into `self` without allocating (capacities are equal).
    pub fn copy_from(&mut self, other: &SampledObject) {
        self.modes.clear();
        self.modes
            .extend_from_slice(&other.modes[..other.modes.len().min(MAX_MODES)]);
        self.bands.clear();
        self.bands
            .extend_from_slice(&other.bands[..other.bands.len().min(MAX_BANDS)]);
        self.reference_size = other.reference_size;
    }
}

/// Mean of successive differences of sorted log2 frequencies: (max − min)/(n − 1) octaves.
pub fn spacing_octaves(freqs: impl Iterator<Item = f64>) -> f64 {
    let (mut lo, mut hi, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0usize);
    for f in freqs {
        let l = f.log2();
        lo = lo.min(l);
        hi = hi.max(l);
        n += 1;
    }
    if n < 2 {
        0.0
    } else {
        (hi - lo) / (n - 1) as f64
    }
}

use super::dsp::scales::erb_centres;
use crate::engine::dsp::DB_PER_NEPER;

/// Draws objects from a preset. Construction allocates (Cholesky factors); sampling does not.
#[derive(Debug)]
pub struct ObjectSampler {
    preset: Preset,
    /// One part per family of a mixture preset, else one for the preset itself.
    parts: Vec<PartSampler>,
    /// Cumulative family weights normalised to end at 1 (one entry per part).
    cumulative: Vec<f64>,
    /// Each part's size class ([`crate::preset::Family::size_class`]); all `None` unless the
    /// preset's families are sized.
    ranges: Vec<Option<SizeClass>>,
    /// The object size draws are for ([`ObjectSampler::set_size`]).
    size: f64,
    scratch: Vec<f64>,
    best: SampledObject,
}

impl Clone for ObjectSampler {
    /// A sampler that samples without allocating, as the original: a derived clone would give
    /// the scratch buffers their lengths as capacities, and the first draw would allocate.
    fn clone(&self) -> Self {
        Self {
            preset: self.preset.clone(),
            parts: self.parts.clone(),
            cumulative: self.cumulative.clone(),
            ranges: self.ranges.clone(),
            size: self.size,
            scratch: Vec::with_capacity(self.scratch.capacity()),
            best: SampledObject::with_capacity(),
        }
    }
}

/// Sampling state of one set of modes, transient and damping law (a preset or one family).
#[derive(Debug, Clone)]
struct PartSampler {
    modes: ModeModel,
    transient: Option<TransientDistribution>,
    damping: Option<DampingModel>,
    mode_chol: Vec<Vec<f64>>,
    band_chol: Vec<Vec<f64>>,
    band_centres: Vec<f64>,
    /// [`peak_amplitude_sum_db`] of the mean object ([`mean_object_modes`], distribution
    /// parts): every drawn object is shifted to it, see [`ObjectSampler::sample`].
    reference_sum_db: Option<f64>,
    /// Transient energy relative to the modes' amplitude sum, [`transient_energy_db`] −
    /// [`amplitude_sum_db`], that every drawn object is given (distribution parts with a
    /// transient): the median of that ratio over [`RATIO_DRAWS`] seeded draws.
    transient_ratio_db: Option<f64>,
    /// Dense mode field, and the mean `log2 f` of the distribution's mean object (NaN for a
    /// fixed list), see [`PartSampler::add_dense`].
    dense: Option<(crate::preset::DenseField, f64)>,
}

impl PartSampler {
    fn new(
        modes: &ModeModel,
        transient: Option<&TransientDistribution>,
        damping: Option<&DampingModel>,
    ) -> Self {
        let mode_chol = match modes {
            ModeModel::Distribution(d) => cholesky(&d.gaussian.covariance).unwrap_or_default(),
            ModeModel::Fixed { .. } => Vec::new(),
        };
        let (band_chol, band_centres) = match transient {
            Some(t) => {
                let mut c = Vec::new();
                erb_centres(t.bands.min(MAX_BANDS), t.low_hz, t.high_hz, &mut c);
                (cholesky(&t.gaussian.covariance).unwrap_or_default(), c)
            }
            None => (Vec::new(), Vec::new()),
        };
        let reference_sum_db = match modes {
            ModeModel::Distribution(d) => {
                let mean = mean_object_modes(d, damping);
                Some(peak_amplitude_sum_db(&mean)).filter(|v| v.is_finite())
            }
            ModeModel::Fixed { .. } => None,
        };
        let transient_ratio_db = match (modes, transient) {
            (ModeModel::Distribution(d), Some(t)) => median_transient_ratio_db(d, t, &mode_chol, &band_chol),
            _ => None,
        };
        Self {
            modes: modes.clone(),
            transient: transient.cloned(),
            damping: damping.copied(),
            mode_chol,
            band_chol,
            band_centres,
            reference_sum_db,
            transient_ratio_db,
            dense: None,
        }
    }

    /// Gives every part its dense field: the preset's own when it has no families, else each
    /// family's (docs/model.md, "Dense mode field").
    fn attach_dense(parts: &mut [PartSampler], preset: &Preset) {
        let fields = preset.families.iter().map(|f| f.dense.as_ref());
        let fields: Vec<_> = if preset.families.is_empty() {
            vec![preset.dense.as_ref()]
        } else {
            fields.collect()
        };
        for (part, field) in parts.iter_mut().zip(fields) {
            let mean_log2_hz = match &part.modes {
                ModeModel::Distribution(d) if d.gaussian.mean.len() >= 3 * d.count && d.count > 0 => {
                    d.gaussian.mean[2 * d.count..3 * d.count].iter().sum::<f64>() / d.count as f64
                }
                _ => f64::NAN,
            };
            part.dense = field.map(|f| (f.clone(), mean_log2_hz));
        }
    }

    /// Adds the dense field's modes to a drawn object (no allocation; nothing without a field).
    /// The field moves with the object's size: by the octaves its drawn modes' mean `log2 f`
    /// lies from the distribution's mean object's (0 for a fixed list).
    fn add_dense(&self, rng: &mut EngineRng, out: &mut SampledObject) {
        let Some((field, mean_log2_hz)) = &self.dense else {
            return;
        };
        let n = out.modes.len();
        let shift = if n > 0 && mean_log2_hz.is_finite() {
            out.modes.iter().map(|m| m.freq_hz.log2()).sum::<f64>() / n as f64 - mean_log2_hz
        } else {
            0.0
        };
        let resonators =
            crate::preset::resonator_slots(n, out.modes.iter().map(|m| m.rise_s > 0.0 || m.ring.rings()));
        super::dense::add_dense_modes(field, shift, resonators, rng, &mut out.modes);
    }
}

/// Decay in dB/s of a drawn mode: `value` is the drawn `ln b` coordinate, `freq_hz` the drawn
/// frequency. Residual coordinates add the law's decay at the drawn frequency; without a law
/// (never for a validated preset) the residual is read as an absolute `ln b`.
fn drawn_decay_db_per_s(
    decay: DecayCoordinates,
    law: Option<&DampingModel>,
    value: f64,
    freq_hz: f64,
) -> f64 {
    let b = match (decay, law) {
        (DecayCoordinates::DampingResidual, Some(law)) => law.residual_base_db_per_s(freq_hz) * value.exp(),
        _ => value.exp(),
    };
    b.clamp(DECAY_RANGE_DB_PER_S.0, DECAY_RANGE_DB_PER_S.1)
}

impl ObjectSampler {
    /// Prepares sampling for a validated preset.
    pub fn new(preset: &Preset) -> Self {
        let (mut parts, weights): (Vec<PartSampler>, Vec<f64>) = if preset.families.is_empty() {
            (
                vec![PartSampler::new(
                    &preset.modes,
                    preset.transient.as_ref(),
                    preset.damping.as_ref(),
                )],
                vec![1.0],
            )
        } else {
            preset
                .families
                .iter()
                .map(|f| {
                    (
                        PartSampler::new(&f.modes, f.transient.as_ref(), f.damping.as_ref()),
                        f.weight.max(0.0),
                    )
                })
                .unzip()
        };
        // One loudness for every family of a mixture (docs/model.md, "Loudness of a drawn
        // object"): a family's fitted levels carry its recordings' arbitrary gains, as one
        // object's do, so its mean object's amplitude sum says nothing about how loud that kind
        // of object is; each family plays at the weighted mean of the families' sums.
        let sums: Vec<(f64, f64)> = parts
            .iter()
            .zip(&weights)
            .filter_map(|(p, &w)| p.reference_sum_db.map(|r| (r, w)))
            .collect();
        let sum_weight: f64 = sums.iter().map(|s| s.1).sum();
        if sums.len() > 1 && sum_weight > 0.0 {
            let common = sums.iter().map(|(r, w)| r * w).sum::<f64>() / sum_weight;
            for p in parts.iter_mut().filter(|p| p.reference_sum_db.is_some()) {
                p.reference_sum_db = Some(common);
            }
        }
        PartSampler::attach_dense(&mut parts, preset);
        let total: f64 = weights.iter().sum();
        let mut acc = 0.0;
        let cumulative = weights
            .iter()
            .map(|w| {
                acc += w;
                if total > 0.0 {
                    acc / total
                } else {
                    1.0
                }
            })
            .collect();
        let ranges = match preset.families.is_empty() {
            true => vec![None],
            false => preset.families.iter().map(|f| f.size_class).collect(),
        };
        Self {
            preset: preset.clone(),
            parts,
            cumulative,
            ranges,
            size: 1.0,
            scratch: Vec::with_capacity(3 * MAX_MODES.max(MAX_BANDS)),
            best: SampledObject::with_capacity(),
        }
    }

    /// The preset this sampler draws from.
    pub fn preset(&self) -> &Preset {
        &self.preset
    }

    /// Whether the preset's families are drawn by object size ([`crate::preset::Family::size_class`]).
    pub fn is_sized(&self) -> bool {
        self.ranges.iter().any(Option::is_some)
    }

    /// The size class a draw at object size `size` draws from: the one that holds `size`,
    /// else the nearest (in octaves); `None` for a preset without sized families.
    pub fn size_class_at(&self, size: f64) -> Option<SizeClass> {
        let distance = |c: &SizeClass| {
            if c.covers(size) {
                0.0
            } else if size <= c.low {
                (c.low.max(1e-12) / size.max(1e-12)).log2()
            } else {
                (size.max(1e-12) / c.high).log2()
            }
        };
        self.ranges
            .iter()
            .flatten()
            .min_by(|a, b| distance(a).total_cmp(&distance(b)))
            .copied()
    }

    /// Sets the object size later draws are for. Real-time safe.
    pub fn set_size(&mut self, size: f64) {
        self.size = size;
    }

    /// The family drawn for uniform number `u`: by weight among all families, or for a sized
    /// preset among the families of the size class at the current size.
    fn pick_part(&self, u: f64) -> usize {
        let last = self.parts.len() - 1;
        let Some(class) = self.size_class_at(self.size) else {
            return self.cumulative.iter().position(|&c| u < c).unwrap_or(last);
        };
        let weight = |i: usize| self.cumulative[i] - if i == 0 { 0.0 } else { self.cumulative[i - 1] };
        let of_class = |i: &usize| self.ranges[*i] == Some(class);
        let total: f64 = (0..self.parts.len()).filter(of_class).map(weight).sum();
        let mut acc = 0.0;
        let mut pick = last;
        for i in (0..self.parts.len()).filter(of_class) {
            pick = i;
            acc += weight(i);
            if u * total < acc {
                break;
            }
        }
        pick
    }

    /// Draws a new object into `out` (no allocation).
    ///
    /// A mixture preset first picks a family (one uniform draw against the cumulative
    /// weights); a preset without families draws no extra number, so its objects for a given
    /// seed are those of format 1. Decays stored relative to the damping law are evaluated at
    /// the drawn frequencies ([`DecayCoordinates::DampingResidual`]).
    ///
    /// Loudness (docs/model.md, "Loudness of a drawn object"): a distribution's drawn
    /// transient is first shifted to its median transient-to-modes ratio, then the
    /// whole object (modes and transient bands by the same dB) so that the sum of its modes'
    /// amplitudes at the tops of their envelopes, [`peak_amplitude_sum_db`], equals that of the
    /// mean object. The sum bounds the modes' summed peak, so no object of a material strikes
    /// louder than that bound allows, and a typical one about as loud as the mean object.
    /// Counted by onset levels, an object whose strongest modes build up (and so never reach
    /// those levels) would play up to ~15 dB quieter than the rest. Without levelling,
    /// the common-mode part of the level draw (per-mode level SDs of 8–17 dB in the fitted
    /// presets, largely the recordings' arbitrary gains) made default hits of the fitted
    /// presets peak anywhere from −16 to +20 dBFS. Only the overall level changes: the modes'
    /// levels relative to each other, and so the object's timbre, are the draw's. A fixed
    /// mode list plays at its own levels.
    pub fn sample(&mut self, rng: &mut EngineRng, out: &mut SampledObject) {
        let k = if self.parts.len() > 1 {
            let u: f64 = rng.random();
            self.pick_part(u)
        } else {
            0
        };
        let part = &self.parts[k];
        out.reference_size = self.ranges[k].map_or(1.0, |c| c.reference);
        out.modes.clear();
        match &part.modes {
            ModeModel::Fixed { modes } => {
                for m in modes.iter().take(MAX_MODES) {
                    out.modes.push(ObjectMode {
                        freq_hz: m.freq_hz,
                        level_db: m.level_db,
                        decay_db_per_s: m.decay_db_per_s,
                        rise_s: m.rise_s,
                        ring: m.ring,
                        inverted: false,
                    });
                }
            }
            ModeModel::Distribution(d) => {
                let count = d.count.min(MAX_MODES);
                let target = d.mean_spacing_octaves;
                let mut best_err = f64::INFINITY;
                for _ in 0..MAX_REJECTION_TRIES {
                    draw(&d.gaussian.mean, &part.mode_chol, rng, &mut self.scratch);
                    out.modes.clear();
                    for i in 0..count {
                        let freq_hz = self.scratch[2 * d.count + i].exp2();
                        out.modes.push(ObjectMode {
                            level_db: self.scratch[i],
                            decay_db_per_s: drawn_decay_db_per_s(
                                d.decay,
                                part.damping.as_ref(),
                                self.scratch[d.count + i],
                                freq_hz,
                            ),
                            freq_hz,
                            rise_s: d.rise_s.get(i).copied().unwrap_or(0.0),
                            ring: d.rings.get(i).copied().unwrap_or_default(),
                            inverted: false,
                        });
                    }
                    let err = if target > 0.0 {
                        (out.mean_spacing_octaves() - target).abs() / target
                    } else {
                        0.0
                    };
                    if err < best_err {
                        best_err = err;
                        self.best.modes.clear();
                        self.best.modes.extend_from_slice(&out.modes);
                    }
                    if err <= d.spacing_tolerance {
                        break;
                    }
                }
                out.modes.clear();
                out.modes.extend_from_slice(&self.best.modes);
                // Unstable: a stable sort takes a heap buffer once the slice outgrows its
                // stack scratch (4 KiB), and this runs on the audio thread.
                out.modes.sort_unstable_by(|a, b| {
                    a.freq_hz
                        .partial_cmp(&b.freq_hz)
                        .unwrap_or(std::cmp::Ordering::Equal)
                });
            }
        }
        out.bands.clear();
        if let Some(t) = &part.transient {
            draw(&t.gaussian.mean, &part.band_chol, rng, &mut self.scratch);
            for (i, &c) in part.band_centres.iter().enumerate() {
                out.bands.push(ObjectBand {
                    centre_hz: c,
                    level_db: self.scratch[i],
                    decay_db_per_s: self.scratch[t.bands + i].exp(),
                });
            }
        }
        if let Some(ratio) = part.transient_ratio_db {
            let sum = amplitude_sum_db(out.modes.iter().map(|m| m.level_db));
            let energy = transient_energy_db(out.bands.iter().map(|b| (b.level_db, b.decay_db_per_s)));
            let shift = sum + ratio - energy;
            if shift.is_finite() {
                for b in &mut out.bands {
                    b.level_db += shift;
                }
            }
        }
        // The dense field draws last, on the same stream, so that the draws above are those of
        // a preset without a field; the object is levelled with its dense modes, which enter
        // the peak bound as the others do, so the bound holds whatever their polarities (left
        // out of the levelling, ~150 in-phase modes of a Ride Cymbal field raise a default hit
        // from under 0 to +10.7 dBFS).
        part.add_dense(rng, out);
        if let Some(reference) = part.reference_sum_db {
            let shift = reference - peak_amplitude_sum_db(&out.modes);
            if shift.is_finite() {
                for m in &mut out.modes {
                    m.level_db += shift;
                }
                for b in &mut out.bands {
                    b.level_db += shift;
                }
            }
        }
    }
}

/// Seeded draws from which [`ObjectSampler`] takes a preset's median transient-to-modes ratio.
pub const RATIO_DRAWS: usize = 255;

/// Median over [`RATIO_DRAWS`] plain draws (seed fixed, no spacing rejection) of the drawn
/// transient's [`transient_energy_db`] minus the drawn modes' [`amplitude_sum_db`]; `None`
/// when a Cholesky factor does not match its distribution or the ratio is not finite.
fn median_transient_ratio_db(
    d: &crate::preset::ModeDistribution,
    t: &crate::preset::TransientDistribution,
    mode_chol: &[Vec<f64>],
    band_chol: &[Vec<f64>],
) -> Option<f64> {
    use rand::SeedableRng;
    if mode_chol.len() != d.gaussian.mean.len() || band_chol.len() != t.gaussian.mean.len() {
        return None;
    }
    let (n, bands) = (d.count.min(MAX_MODES), t.bands.min(MAX_BANDS));
    let mut rng = EngineRng::seed_from_u64(0x7AC7_0500);
    let (mut m, mut b) = (Vec::new(), Vec::new());
    let mut ratios: Vec<f64> = (0..RATIO_DRAWS)
        .map(|_| {
            draw(&d.gaussian.mean, mode_chol, &mut rng, &mut m);
            draw(&t.gaussian.mean, band_chol, &mut rng, &mut b);
            transient_energy_db((0..bands).map(|i| (b[i], b[t.bands + i].exp())))
                - amplitude_sum_db(m[..n].iter().copied())
        })
        .collect();
    ratios.sort_by(f64::total_cmp);
    Some(ratios[RATIO_DRAWS / 2]).filter(|v| v.is_finite())
}

/// Energy (dB re 1, ∫ envelope² dt) of noise bands given as (onset level dB, decay dB/s):
/// `10·log10 Σ 10^(level/10) / (decay·ln10/10)`.
pub fn transient_energy_db(bands: impl Iterator<Item = (f64, f64)>) -> f64 {
    let per_db = std::f64::consts::LN_10 / 10.0;
    10.0 * bands
        .map(|(level, decay)| 10f64.powf(level / 10.0) / (decay.max(1e-3) * per_db))
        .sum::<f64>()
        .log10()
}

/// `20·log10 Σ 10^(level/20)`: the sum of onset amplitudes of modes at `levels_db` (dB), which
/// bounds their summed signal's peak; `−∞` for no modes.
pub fn amplitude_sum_db(levels_db: impl Iterator<Item = f64>) -> f64 {
    20.0 * levels_db.map(|l| 10f64.powf(l / 20.0)).sum::<f64>().log10()
}

/// The highest value of a build-up mode's envelope `e^{−σt}·(1 − e^{−t/τ})` (docs/model.md §3,
/// "Build-up"), σ the amplitude decay rate in 1/s: `1/(1 + στ) · (στ/(1 + στ))^{στ}`, reached at
/// `t = τ·ln(1 + 1/(στ))`; 1 for a mode without build-up (τ = 0). A mode that swells slowly
/// and dies fast never comes near its onset level `A`: one dying at 700 dB/s under a 64 ms
/// build-up (the extractor's longest) peaks 24 dB under it.
pub fn build_up_peak_factor(decay_db_per_s: f64, rise_s: f64) -> f64 {
    let st = decay_db_per_s.max(0.0) / DB_PER_NEPER * rise_s.max(0.0);
    if !(st > 0.0) || !st.is_finite() {
        return 1.0;
    }
    (st / (1.0 + st)).powf(st) / (1.0 + st)
}

/// `20·log10 Σ A_m·P_m`: the modes' amplitudes at the tops of their envelopes
/// ([`build_up_peak_factor`]), which bounds their summed signal's peak whether or not they
/// build up; equal to [`amplitude_sum_db`] when none does. `−∞` for no modes.
pub fn peak_amplitude_sum_db(modes: &[ObjectMode]) -> f64 {
    20.0 * modes
        .iter()
        .map(|m| 10f64.powf(m.level_db / 20.0) * build_up_peak_factor(m.decay_db_per_s, m.rise_s))
        .sum::<f64>()
        .log10()
}

/// The mean object of a mode distribution: each rank at its mean level and frequency, its decay
/// evaluated as a draw's is (relative to `law` where the preset stores residuals), and its
/// build-up. Allocates; for set-up and tests.
pub fn mean_object_modes(d: &ModeDistribution, law: Option<&DampingModel>) -> Vec<ObjectMode> {
    let n = d.count.min(MAX_MODES);
    if d.gaussian.mean.len() < 3 * d.count {
        return Vec::new();
    }
    let mean = &d.gaussian.mean;
    (0..n)
        .map(|i| {
            let freq_hz = mean[2 * d.count + i].exp2();
            ObjectMode {
                freq_hz,
                level_db: mean[i],
                decay_db_per_s: drawn_decay_db_per_s(d.decay, law, mean[d.count + i], freq_hz),
                rise_s: d.rise_s.get(i).copied().unwrap_or(0.0),
                ring: d.rings.get(i).copied().unwrap_or_default(),
                inverted: false,
            }
        })
        .collect()
}

/// `out = mean + L·z`, z standard normal (L lower-triangular Cholesky factor of the
/// covariance, so `out ~ N(mean, L·Lᵀ)`). With a factor of the wrong size, returns the mean.
/// Public so tests can check the draw's statistics; never allocates once `out` has capacity.
pub fn draw(mean: &[f64], chol: &[Vec<f64>], rng: &mut EngineRng, out: &mut Vec<f64>) {
    out.clear();
    let n = mean.len();
    if chol.len() != n {
        out.extend_from_slice(mean);
        return;
    }
    // z stored after the result to avoid a second buffer.
    for _ in 0..n {
        let z: f64 = rng.sample(StandardNormal);
        out.push(z);
    }
    for i in (0..n).rev() {
        let mut s = mean[i];
        for (k, &l) in chol[i].iter().enumerate().take(i + 1) {
            s += l * out[k];
        }
        out[i] = s;
    }
}

/// Re-hit variation (Traer §2.1): each mode's onset *power* gets Gaussian noise with
/// SD = `variation` × the mean mode power (`variation = 0.2` is Traer's 20 %). Writes the
/// perturbed levels (dB) into `levels_db`, which must be as long as `modes`.
pub fn perturb_levels(modes: &[ObjectMode], variation: f64, rng: &mut EngineRng, levels_db: &mut [f64]) {
    let n = modes.len().min(levels_db.len());
    if n == 0 {
        return;
    }
    let mean_power = modes[..n]
        .iter()
        .map(|m| 10f64.powf(m.level_db / 10.0))
        .sum::<f64>()
        / n as f64;
    let sd = variation.max(0.0) * mean_power;
    for i in 0..n {
        let p = 10f64.powf(modes[i].level_db / 10.0);
        let z: f64 = rng.sample(StandardNormal);
        // A power cannot go negative; floor at 1e-6 of the original (−60 dB) instead of silencing.
        let q = (p + sd * z).max(p * 1e-6);
        levels_db[i] = 10.0 * q.log10();
    }
}
