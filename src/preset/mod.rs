//! Material presets: the stored mode distributions of docs/model.md §3–4 (Traer et al. 2019 §2.1,
//! Sterling et al. 2019 §1.2), their JSON format, and validation with readable errors.
//!
//! A preset describes a *material*, not one object: either a multivariate Gaussian over the
//! per-mode parameter vector (every draw is a new, plausible object) or a fixed mode list (tuned
//! objects, tests). The format is documented in `docs/presets.md`; bump [`FORMAT_VERSION`] and add
//! a migration in [`Preset::from_json`] whenever a field changes meaning.
//!
//! ## Parameterisation (why these coordinates)
//! Per mode `m` of `M`: onset level `a_m` in dB, `ln(b_m)` with `b_m` the decay in dB/s, and
//! `log2(f_m)` with `f_m` in Hz. Levels are already logarithmic; decay rates and frequencies are
//! positive and spread over decades, so their logarithms are close to Gaussian and a Gaussian draw
//! can never produce a negative decay or frequency. The vector is laid out in three blocks:
//! `[a_0..a_M, ln b_0..ln b_M, log2 f_0..log2 f_M]`, modes sorted by mean frequency.
//!
//! Levels are in dB re 1 output unit per N·s of contact impulse at the reference object size
//! (`size = 1`); the engine's output gain is applied on top.

use crate::engine::dsp::linalg::cholesky;
use crate::engine::limits::MAX_DISTRIBUTION_MODES;
use crate::engine::limits::{MAX_BANDS, MAX_MODES};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

pub mod dense;
mod worst_case;
pub use dense::{DenseBand, DenseField};
pub use worst_case::{worst_case_build_up_preset, worst_case_preset, worst_case_ring_preset};

/// Current preset format version. Files with a higher version are rejected; lower ones migrate.
///
/// Version 2 added [`Preset::families`] (a weighted mixture of object families) and
/// [`ModeDistribution::decay`] (decays stored relative to the damping law). Both default to the
/// version-1 meaning (no families, absolute decays), so a version-1 file loads unchanged.
/// Version 3 added per-mode build-up times ([`ModeDistribution::rise_s`], [`FixedMode::rise_s`]);
/// absent means none, so version-1 and -2 files load unchanged, and a version-2 reader refuses a
/// version-3 file instead of playing its swelling modes as clicks.
/// Version 4 added the dense mode field ([`Preset::dense`], [`Family::dense`]); absent means
/// none, so older files load unchanged, and a version-3 reader refuses a version-4 file instead
/// of playing a cymbal with a few dozen of its hundreds of partials.
/// Version 5 added a dense band's build-up time ([`DenseBand::rise_s`]); absent means none, so
/// older files load unchanged, and a version-4 reader refuses a version-5 file instead of
/// starting the band's modes at their full level, raised to keep the build-up's energy.
/// Version 6 added per-mode rings ([`ModeDistribution::rings`], [`FixedMode::ring`]); absent
/// means none, so older files load unchanged, and a version-5 reader refuses a version-6 file
/// instead of playing its modes' knocks without the ring after them.
/// Version 7 added a family's size class ([`Family::size_class`]) and the origin
/// [`Origin::Measured`]; absent means a family drawn at every size, so older files load
/// unchanged, and a version-6 reader refuses a version-7 file instead of drawing a matchbox's
/// modes for a wardrobe.
pub const FORMAT_VERSION: u32 = 7;

/// Lowest and highest frequency a preset may name, in Hz (below hearing / far above any fs).
pub const FREQ_RANGE_HZ: (f64, f64) = (10.0, 100_000.0);
/// Decay range in dB/s: 0.01 dB/s is a bell ringing for ~100 min, 1e5 dB/s dies in 0.6 ms.
pub const DECAY_RANGE_DB_PER_S: (f64, f64) = (0.0, 1.0e5);
/// Onset level range in dB.
pub const LEVEL_RANGE_DB: (f64, f64) = (-200.0, 100.0);
/// Longest build-up time τ a mode may have, s. Why 1 s: the extractor's build-ups stop at
/// 64 ms (`fit::recording::extract::ATTACK_GRID_S`) and a merged group's fitted τ at
/// `fit::modes::MAX_FIT_RISE_S`; a swell slower than a second is no longer the response to a
/// strike.
pub const MAX_RISE_S: f64 = 1.0;
/// Largest ring share ([`ModeRing::share`]) a mode may have: a mode whose ring carries more at
/// its onset has no knock to speak of, and its own decay is the ring's.
pub const MAX_RING_SHARE: f64 = 0.9;

/// A mode's ring (docs/model.md "Ring"): a second, slower stage after its knock. The mode sounds
/// `g·((1 − s)·e^{−σt} + s·e^{−rσt})·cos(ωt)`, `s` = `share`, `r` = `decay_ratio`, `σ` the
/// mode's own decay. The default (share 0) is no ring.
///
/// Why the ring's decay as a ratio of the mode's: a draw's decay comes from the damping law at
/// the drawn frequency and the object's damping control scales it; the ring, measured in the
/// same band as its knock, follows both.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ModeRing {
    /// Amplitude share `s` of the ring at the onset: 0 (no ring) up to [`MAX_RING_SHARE`].
    pub share: f64,
    /// The ring's decay as a fraction of the mode's own, in (0, 1).
    pub decay_ratio: f64,
}

impl ModeRing {
    /// Whether the mode has a ring (a share above 0).
    pub fn rings(&self) -> bool {
        self.share > 0.0
    }

    /// Validates the ring of the mode named `field`.
    fn validate(&self, field: &str) -> Result<(), PresetError> {
        check_range(&format!("{field}.share"), self.share, (0.0, MAX_RING_SHARE))?;
        if self.rings() && !(self.decay_ratio > 0.0 && self.decay_ratio < 1.0) {
            return Err(err(
                format!("{field}.decay_ratio"),
                format!(
                    "a ring decays slower than its mode: must be in (0, 1), got {}",
                    self.decay_ratio
                ),
            ));
        }
        Ok(())
    }
}

/// Refuses a mode (named `field`) that both builds up and rings: the engine plays either as a
/// second resonator beside the mode, not both.
fn check_one_partner(field: &str, rise_s: f64, ring: &ModeRing) -> Result<(), PresetError> {
    if rise_s > 0.0 && ring.rings() {
        return Err(err(
            field.to_owned(),
            "a mode may build up (rise_s) or ring (ring), not both",
        ));
    }
    Ok(())
}

/// Whether a preset was fitted from recordings, derived from published data, or is a fixed list.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Origin {
    /// Fitted by `tactus fit` from recordings listed in the provenance.
    Fitted,
    /// Derived from published damping data and physical reasoning (see provenance notes).
    Derived,
    /// Fitted by `tactus fit` from measured mode tables (frequencies, levels and decays of
    /// objects' modes, e.g. from an experiment or a FEM model) listed in the provenance.
    Measured,
    /// Hand-written or provisional; not a measurement.
    Provisional,
}

/// Where a preset came from.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Provenance {
    /// Source files (recordings) or publications.
    pub sources: Vec<String>,
    /// Extraction/fit method, e.g. "iterative spectrogram matching + EMG damping MLE".
    pub method: String,
    /// ISO date of creation.
    pub date: String,
    /// Version of the tool that wrote it.
    pub tool_version: String,
    /// Free text: assumptions, caveats.
    pub notes: String,
}

/// One mode of a fixed mode list.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FixedMode {
    /// Frequency in Hz at `size = 1`.
    pub freq_hz: f64,
    /// Onset level in dB (see module docs for the reference).
    pub level_db: f64,
    /// Decay in dB/s (≥ 0; 0 rings forever).
    pub decay_db_per_s: f64,
    /// Build-up time τ in s (0: none): the mode sounds `e^{−σt}·(1 − e^{−t/τ})` (docs/model.md
    /// "Build-up"); up to [`MAX_RISE_S`]. Absent in a file = 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub rise_s: f64,
    /// The mode's ring after its knock ([`ModeRing`]); absent in a file = none.
    #[serde(default, skip_serializing_if = "no_ring")]
    pub ring: ModeRing,
}

fn no_ring(r: &ModeRing) -> bool {
    !r.rings()
}

impl FixedMode {
    /// Whether the engine plays this mode with a second resonator (a build-up or a ring).
    pub fn has_partner(&self) -> bool {
        self.rise_s > 0.0 || self.ring.rings()
    }
}

pub(crate) fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// Multivariate Gaussian over a parameter vector: mean and full covariance (row-major rows).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Gaussian {
    /// Mean vector.
    pub mean: Vec<f64>,
    /// Covariance matrix, `mean.len()` rows of `mean.len()` values; symmetric positive definite.
    pub covariance: Vec<Vec<f64>>,
}

/// Distribution of mode parameters: `mean.len() == 3 * count` (layout in module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModeDistribution {
    /// Number of modes `M` per sampled object.
    pub count: usize,
    /// Gaussian over `[a_0..a_M, ln b_0..ln b_M, log2 f_0..log2 f_M]`.
    pub gaussian: Gaussian,
    /// Measured mean spacing between adjacent sorted mode frequencies, in octaves
    /// (mean of successive `log2 f` differences). The sampler rejects objects whose spacing is
    /// more than [`ModeDistribution::spacing_tolerance`] away from it (Traer §2.1: 10 %).
    pub mean_spacing_octaves: f64,
    /// Relative tolerance on the spacing for rejection sampling (default 0.10).
    #[serde(default = "default_spacing_tolerance")]
    pub spacing_tolerance: f64,
    /// What the `ln b` block of the Gaussian holds (default: absolute decays, format 1).
    #[serde(default)]
    pub decay: DecayCoordinates,
    /// Per mode (in the Gaussian's frequency order), the build-up time τ in s that every drawn
    /// object's mode gets: it sounds `e^{−σt}·(1 − e^{−t/τ})` (docs/model.md "Build-up"); 0 =
    /// none, up to [`MAX_RISE_S`]. Empty (absent in a file) = no build-ups, so files without it
    /// keep their meaning. Not part of the Gaussian: a build-up is a property of the fitted
    /// mode, not a coordinate the fit has enough recordings per mode to give a spread.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rise_s: Vec<f64>,
    /// Per mode (in the Gaussian's frequency order), the ring after its knock that every drawn
    /// object's mode gets ([`ModeRing`]). Empty (absent in a file) = no rings. Not part of the
    /// Gaussian, as [`ModeDistribution::rise_s`].
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rings: Vec<ModeRing>,
}

impl ModeDistribution {
    /// Per mode, whether the engine plays it with a second resonator (a build-up or a ring).
    pub fn partners(&self) -> impl Iterator<Item = bool> + '_ {
        (0..self.count).map(|i| {
            self.rise_s.get(i).is_some_and(|&r| r > 0.0) || self.rings.get(i).is_some_and(ModeRing::rings)
        })
    }
}

/// Meaning of the `ln b` block of a [`ModeDistribution`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DecayCoordinates {
    /// `ln b` with `b` the decay in dB/s, drawn independently of the frequency (format 1).
    #[default]
    Absolute,
    /// `ln(b / b_law(f))`: the deviation of each mode's decay from the damping law at its
    /// frequency ([`DampingModel::residual_base_db_per_s`], the law held at least at
    /// [`MIN_LAW_DECAY_DB_PER_S`]). A draw evaluates the law at the
    /// *drawn* frequency and adds the drawn deviation, so decay grows with frequency as the
    /// recordings' does (Sterling 2019 eq. 1.5). Needs a damping law beside the distribution.
    DampingResidual,
}

fn default_spacing_tolerance() -> f64 {
    0.10
}

/// How the modes of an object are obtained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum ModeModel {
    /// Sample each object from a distribution.
    Distribution(ModeDistribution),
    /// Always the same modes (no randomness apart from per-hit variation).
    Fixed {
        /// The modes.
        modes: Vec<FixedMode>,
    },
}

/// Distribution of the noise-band transient (Traer eq. 3): `N` ERB-spaced bands between
/// `low_hz` and `high_hz`; Gaussian over `[α_0..α_N (dB), ln β_0..ln β_N (β in dB/s)]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransientDistribution {
    /// Number of bands `N` (Traer: 30).
    pub bands: usize,
    /// Centre of the lowest band in Hz.
    pub low_hz: f64,
    /// Centre of the highest band in Hz (bands above 0.49·fs are skipped at render time).
    pub high_hz: f64,
    /// Gaussian over the `2N` vector.
    pub gaussian: Gaussian,
}

/// Per-mode damping law `c(ω) = α1 + α2·ω^(2·α3)` (Sterling eq. 1.5; α3 = 1 is Rayleigh), with
/// the EMG noise model's σ and η. Amplitude decays as `exp(−c·t/2)`, i.e. `b = 20·log10(e)·c/2` dB/s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DampingModel {
    /// α1 in 1/s.
    pub alpha1: f64,
    /// α2 in s^(2α3−1) (s for Rayleigh).
    pub alpha2: f64,
    /// α3, dimensionless (1 = Rayleigh).
    #[serde(default = "one")]
    pub alpha3: f64,
    /// σ of the Gaussian part of the EMG residual, 1/s (0 if unknown).
    #[serde(default)]
    pub sigma: f64,
    /// η, rate of the exponential part of the EMG residual, s (0 if unknown).
    #[serde(default)]
    pub eta: f64,
}

fn one() -> f64 {
    1.0
}

impl DampingModel {
    /// Damping coefficient `c` in 1/s at angular frequency `omega` (rad/s).
    pub fn c(&self, omega: f64) -> f64 {
        self.alpha1 + self.alpha2 * omega.powf(2.0 * self.alpha3)
    }

    /// Decay in dB/s at frequency `freq_hz`.
    pub fn decay_db_per_s(&self, freq_hz: f64) -> f64 {
        c_to_db_per_s(self.c(std::f64::consts::TAU * freq_hz))
    }

    /// The decay that a mode's [`DecayCoordinates::DampingResidual`] is relative to at
    /// `freq_hz`: the law, at least [`MIN_LAW_DECAY_DB_PER_S`]. The fit divides by it and a
    /// draw multiplies by it, so both must floor it alike.
    pub fn residual_base_db_per_s(&self, freq_hz: f64) -> f64 {
        self.decay_db_per_s(freq_hz).max(MIN_LAW_DECAY_DB_PER_S)
    }
}

/// Smallest decay, dB/s, that a damping law stands for when decays are stored relative to it
/// ([`DampingModel::residual_base_db_per_s`]), and the smallest decay a fitted mode is given
/// (a T60 of 20 minutes: no recording measures slower). Why a floor on the law: a law fitted
/// to cymbal modes falls to 10⁻⁶ dB/s at 60 Hz (`α2·ω³`); a residual relative to that would
/// be a ratio to a number no recording measured.
pub const MIN_LAW_DECAY_DB_PER_S: f64 = 0.05;

/// `b = 20·log10(e)·c/2`: damping coefficient (1/s) to decay in dB/s.
pub fn c_to_db_per_s(c: f64) -> f64 {
    10.0 * std::f64::consts::LOG10_E * c
}

/// A material preset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Preset {
    /// Format version, see [`FORMAT_VERSION`].
    pub format_version: u32,
    /// Display name, e.g. "Wood".
    pub name: String,
    /// Material class: wood, metal, glass, ceramic, plastic, stone, cardboard, or other.
    pub material_class: String,
    /// Fitted, derived or provisional.
    pub origin: Origin,
    /// Where it came from.
    #[serde(default)]
    pub provenance: Provenance,
    /// Modes: a distribution or a fixed list.
    pub modes: ModeModel,
    /// Noise-band transient distribution; `None` = no transient.
    #[serde(default)]
    pub transient: Option<TransientDistribution>,
    /// Damping law (informative for fitted presets; used to derive decays for derived ones).
    #[serde(default)]
    pub damping: Option<DampingModel>,
    /// Default contact stiffness k in N/m for the impact models.
    pub contact_stiffness_n_per_m: f64,
    /// Hunt–Crossley exponent α of the striker's contact, 1 ..= 3 (docs/model.md §5, "Strike
    /// speed and brightness"). The contact time scales as `v^((1−α)/(1+α))`, so α sets how much
    /// brighter a harder strike is: 1 not at all, Hertz's 3/2 by `v^(−1/5)`. Fitted from
    /// recordings with velocity layers; absent = [`crate::engine::force::HC_DEFAULT_EXPONENT`].
    #[serde(
        default = "default_contact_exponent",
        skip_serializing_if = "is_default_contact_exponent"
    )]
    pub contact_exponent: f64,
    /// Object families the material is a mixture of (format 2). Empty: every object is drawn
    /// from `modes`/`transient`/`damping` above. Otherwise a draw first picks a family with
    /// probability proportional to its weight, then an object of that family; the top-level
    /// fields then describe the material pooled over all families (for listings).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub families: Vec<Family>,
    /// Dense mode field added to every object drawn from `modes` (format 4; used when
    /// `families` is empty, each family has its own). `None`: no dense modes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dense: Option<DenseField>,
}

fn default_contact_exponent() -> f64 {
    crate::engine::force::HC_DEFAULT_EXPONENT
}

fn is_default_contact_exponent(a: &f64) -> bool {
    *a == crate::engine::force::HC_DEFAULT_EXPONENT
}

/// One object family of a mixture preset (e.g. the marimba bars of a wood preset): its own
/// mode distribution, transient and damping law, fitted from that family's recordings only.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Family {
    /// Family name, e.g. "marimba".
    pub name: String,
    /// Relative weight (> 0); draws pick a family with probability weight / Σ weights.
    pub weight: f64,
    /// Modes of this family's objects.
    pub modes: ModeModel,
    /// Noise-band transient of this family; `None` = no transient.
    #[serde(default)]
    pub transient: Option<TransientDistribution>,
    /// Damping law of this family (required when its decays are [`DecayCoordinates::DampingResidual`]).
    #[serde(default)]
    pub damping: Option<DampingModel>,
    /// Dense mode field of this family's objects (format 4); `None`: no dense modes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dense: Option<DenseField>,
    /// The object sizes at which this family is drawn (format 7); `None`: every size, its
    /// frequencies those of size 1. Why: measured tables of one material differ by object
    /// size in decay and spectrum, not only in pitch, so the size picks its table's family
    /// (docs/measured.md, "Size").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size_class: Option<SizeClass>,
}

/// The range of the `size` setting (object scale) a family of a sized preset is drawn at, and
/// the size at which it plays its own frequencies.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SizeClass {
    /// Lowest size, exclusive.
    pub low: f64,
    /// Highest size, inclusive.
    pub high: f64,
    /// The size at which the family's modes sound at their stored frequencies; at size `s`
    /// they sound at `reference / s` times them.
    pub reference: f64,
}

impl SizeClass {
    /// Whether `size` falls in this class.
    pub fn covers(&self, size: f64) -> bool {
        size > self.low && size <= self.high
    }
}

/// What is wrong with a preset: which field and why.
#[derive(Debug, Clone, PartialEq)]
pub struct PresetError {
    /// File the preset came from, if any.
    pub file: Option<String>,
    /// Field path, e.g. `modes.gaussian.covariance`.
    pub field: String,
    /// Human-readable reason.
    pub reason: String,
}

impl fmt::Display for PresetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.file {
            Some(file) => write!(f, "preset {file}: ")?,
            None => write!(f, "preset: ")?,
        }
        // Whole-file problems (unreadable, not JSON) have no field to point at.
        if self.field.is_empty() || self.field.starts_with('(') {
            write!(f, "{}", self.reason)
        } else {
            write!(f, "field `{}`: {}", self.field, self.reason)
        }
    }
}

impl std::error::Error for PresetError {}

fn err(field: impl Into<String>, reason: impl Into<String>) -> PresetError {
    PresetError {
        file: None,
        field: field.into(),
        reason: reason.into(),
    }
}

fn check_range(field: &str, v: f64, (lo, hi): (f64, f64)) -> Result<(), PresetError> {
    if !v.is_finite() {
        return Err(err(field, format!("must be a finite number, got {v}")));
    }
    if v < lo || v > hi {
        return Err(err(field, format!("{v} is outside the range [{lo}, {hi}]")));
    }
    Ok(())
}

impl Gaussian {
    fn validate(&self, field: &str, dim: usize) -> Result<(), PresetError> {
        if self.mean.len() != dim {
            return Err(err(
                format!("{field}.mean"),
                format!("expected {dim} values, got {}", self.mean.len()),
            ));
        }
        if let Some(i) = self.mean.iter().position(|v| !v.is_finite()) {
            return Err(err(format!("{field}.mean[{i}]"), "must be finite"));
        }
        if self.covariance.len() != dim {
            return Err(err(
                format!("{field}.covariance"),
                format!("expected {dim} rows, got {}", self.covariance.len()),
            ));
        }
        for (i, row) in self.covariance.iter().enumerate() {
            if row.len() != dim {
                return Err(err(
                    format!("{field}.covariance[{i}]"),
                    format!("expected {dim} values, got {}", row.len()),
                ));
            }
            if let Some(j) = row.iter().position(|v| !v.is_finite()) {
                return Err(err(format!("{field}.covariance[{i}][{j}]"), "must be finite"));
            }
        }
        for i in 0..dim {
            for j in 0..i {
                let (a, b) = (self.covariance[i][j], self.covariance[j][i]);
                if (a - b).abs() > 1e-9 * (1.0 + a.abs().max(b.abs())) {
                    return Err(err(
                        format!("{field}.covariance[{i}][{j}]"),
                        format!("matrix is not symmetric ({a} vs {b} at [{j}][{i}])"),
                    ));
                }
            }
        }
        if cholesky(&self.covariance).is_none() {
            return Err(err(
                format!("{field}.covariance"),
                "matrix is not positive definite (regularise it, e.g. add a small diagonal)",
            ));
        }
        Ok(())
    }
}

/// Resonators the engine needs for `count` modes, `partners` saying per mode whether it has a
/// second resonator: one per mode, plus one per build-up (docs/model.md "Build-up": a mode that
/// builds up is the difference of two resonators) or ring ("Ring": the sum of two).
pub fn resonator_slots(count: usize, partners: impl Iterator<Item = bool>) -> usize {
    count + partners.filter(|&p| p).count()
}

/// Validates one set of modes, transient and damping law; `p` prefixes the field names
/// (`""` for the preset's own, `"families[i]."` for a family's).
fn validate_parts(
    p: &str,
    modes: &ModeModel,
    transient: Option<&TransientDistribution>,
    damping: Option<&DampingModel>,
) -> Result<(), PresetError> {
    match modes {
        ModeModel::Fixed { modes } => validate_fixed(p, modes)?,
        ModeModel::Distribution(d) => validate_distribution(p, d, damping.is_some())?,
    }
    if let Some(t) = transient {
        if t.bands == 0 || t.bands > MAX_BANDS {
            return Err(err(
                format!("{p}transient.bands"),
                format!(
                    "must be 1..={MAX_BANDS} (the engine's band limit), got {}",
                    t.bands
                ),
            ));
        }
        check_range(&format!("{p}transient.low_hz"), t.low_hz, FREQ_RANGE_HZ)?;
        check_range(&format!("{p}transient.high_hz"), t.high_hz, FREQ_RANGE_HZ)?;
        if t.high_hz <= t.low_hz {
            return Err(err(
                format!("{p}transient.high_hz"),
                "must be above transient.low_hz",
            ));
        }
        t.gaussian
            .validate(&format!("{p}transient.gaussian"), 2 * t.bands)?;
    }
    if let Some(d) = damping {
        check_range(&format!("{p}damping.alpha1"), d.alpha1, (0.0, 1.0e5))?;
        check_range(&format!("{p}damping.alpha2"), d.alpha2, (0.0, 1.0))?;
        check_range(&format!("{p}damping.alpha3"), d.alpha3, (0.5, 1.5))?;
        check_range(&format!("{p}damping.sigma"), d.sigma, (0.0, 1.0e5))?;
        check_range(&format!("{p}damping.eta"), d.eta, (0.0, 1.0e5))?;
    }
    Ok(())
}

/// Validates a fixed mode list (`p` as [`validate_parts`]).
fn validate_fixed(p: &str, modes: &[FixedMode]) -> Result<(), PresetError> {
    if modes.is_empty() {
        return Err(err(
            format!("{p}modes.modes"),
            "a fixed mode list needs at least one mode",
        ));
    }
    let slots = resonator_slots(modes.len(), modes.iter().map(FixedMode::has_partner));
    if slots > MAX_MODES {
        return Err(err(
            format!("{p}modes.modes"),
            format!(
                "at most {MAX_MODES} resonators (the engine's mode limit; a mode with a \
                 build-up or a ring takes two), got {} modes needing {slots}",
                modes.len()
            ),
        ));
    }
    for (i, m) in modes.iter().enumerate() {
        check_range(&format!("{p}modes.modes[{i}].freq_hz"), m.freq_hz, FREQ_RANGE_HZ)?;
        check_range(
            &format!("{p}modes.modes[{i}].level_db"),
            m.level_db,
            LEVEL_RANGE_DB,
        )?;
        check_range(
            &format!("{p}modes.modes[{i}].decay_db_per_s"),
            m.decay_db_per_s,
            DECAY_RANGE_DB_PER_S,
        )?;
        check_range(
            &format!("{p}modes.modes[{i}].rise_s"),
            m.rise_s,
            (0.0, MAX_RISE_S),
        )?;
        m.ring.validate(&format!("{p}modes.modes[{i}].ring"))?;
        check_one_partner(&format!("{p}modes.modes[{i}]"), m.rise_s, &m.ring)?;
    }
    Ok(())
}

/// Validates a mode distribution (`p` as [`validate_parts`]); `has_damping`: the set has a
/// damping law, which decays relative to it need.
fn validate_distribution(p: &str, d: &ModeDistribution, has_damping: bool) -> Result<(), PresetError> {
    if d.count == 0 || d.count > MAX_DISTRIBUTION_MODES {
        return Err(err(
            format!("{p}modes.count"),
            format!(
                "must be 1..={MAX_DISTRIBUTION_MODES} (the engine's limit for a Gaussian's modes; \
                 more modes come from a dense field), got {}",
                d.count
            ),
        ));
    }
    d.gaussian.validate(&format!("{p}modes.gaussian"), 3 * d.count)?;
    if !d.rise_s.is_empty() && d.rise_s.len() != d.count {
        return Err(err(
            format!("{p}modes.rise_s"),
            format!(
                "expected {} values (one per mode) or none, got {}",
                d.count,
                d.rise_s.len()
            ),
        ));
    }
    for (i, &r) in d.rise_s.iter().enumerate() {
        check_range(&format!("{p}modes.rise_s[{i}]"), r, (0.0, MAX_RISE_S))?;
    }
    if !d.rings.is_empty() && d.rings.len() != d.count {
        return Err(err(
            format!("{p}modes.rings"),
            format!(
                "expected {} rings (one per mode) or none, got {}",
                d.count,
                d.rings.len()
            ),
        ));
    }
    for (i, r) in d.rings.iter().enumerate() {
        r.validate(&format!("{p}modes.rings[{i}]"))?;
        check_one_partner(
            &format!("{p}modes.rings[{i}]"),
            d.rise_s.get(i).copied().unwrap_or(0.0),
            r,
        )?;
    }
    let slots = resonator_slots(d.count, d.partners());
    if slots > MAX_MODES {
        return Err(err(
            format!("{p}modes.rise_s"),
            format!(
                "{} modes with {} build-ups or rings need {slots} resonators, at most {MAX_MODES} \
                 (the engine's mode limit; a mode with a build-up or a ring takes two)",
                d.count,
                slots - d.count
            ),
        ));
    }
    let m = d.count;
    for i in 0..m {
        check_range(
            &format!("{p}modes.gaussian.mean[{i}] (level dB)"),
            d.gaussian.mean[i],
            LEVEL_RANGE_DB,
        )?;
        let lnb = d.gaussian.mean[m + i];
        check_range(
            &format!("{p}modes.gaussian.mean[{}] (ln decay)", m + i),
            lnb,
            (-10.0, 12.0),
        )?;
        let lf = d.gaussian.mean[2 * m + i];
        check_range(
            &format!("{p}modes.gaussian.mean[{}] (log2 Hz)", 2 * m + i),
            lf,
            (FREQ_RANGE_HZ.0.log2(), FREQ_RANGE_HZ.1.log2()),
        )?;
    }
    check_range(
        &format!("{p}modes.mean_spacing_octaves"),
        d.mean_spacing_octaves,
        (0.0, 20.0),
    )?;
    check_range(
        &format!("{p}modes.spacing_tolerance"),
        d.spacing_tolerance,
        (0.0, 10.0),
    )?;
    if d.decay == DecayCoordinates::DampingResidual && !has_damping {
        return Err(err(
            format!("{p}modes.decay"),
            format!("\"damping_residual\" decays need a damping law: add {p}damping or use \"absolute\""),
        ));
    }
    Ok(())
}

impl Preset {
    /// Checks every field; the error names the field and the reason.
    pub fn validate(&self) -> Result<(), PresetError> {
        if self.format_version == 0 || self.format_version > FORMAT_VERSION {
            return Err(err(
                "format_version",
                format!(
                    "version {} is not supported (this build reads 1..={FORMAT_VERSION})",
                    self.format_version
                ),
            ));
        }
        if self.name.trim().is_empty() {
            return Err(err("name", "must not be empty"));
        }
        validate_parts("", &self.modes, self.transient.as_ref(), self.damping.as_ref())?;
        if let Some(d) = &self.dense {
            d.validate("")?;
        }
        for (i, f) in self.families.iter().enumerate() {
            let at = format!("families[{i}]");
            if f.name.trim().is_empty() {
                return Err(err(format!("{at}.name"), "must not be empty"));
            }
            if !(f.weight.is_finite() && f.weight > 0.0) {
                return Err(err(
                    format!("{at}.weight"),
                    format!("must be a finite number above 0, got {}", f.weight),
                ));
            }
            validate_parts(
                &format!("{at}."),
                &f.modes,
                f.transient.as_ref(),
                f.damping.as_ref(),
            )?;
            if let Some(d) = &f.dense {
                d.validate(&format!("{at}."))?;
            }
            if let Some(c) = f.size_class {
                if !([c.low, c.high, c.reference].iter().all(|v| v.is_finite())
                    && c.low >= 0.0
                    && c.high > c.low
                    && c.reference > 0.0)
                {
                    return Err(err(
                        format!("{at}.size_class"),
                        format!(
                            "needs 0 <= low < high and reference > 0, all finite; got low {}, high {}, reference {}",
                            c.low, c.high, c.reference
                        ),
                    ));
                }
            }
        }
        check_range(
            "contact_stiffness_n_per_m",
            self.contact_stiffness_n_per_m,
            (1.0, 1.0e12),
        )?;
        check_range("contact_exponent", self.contact_exponent, (1.0, 3.0))?;
        Ok(())
    }

    /// Parses and validates a preset from JSON text. `file` names the source in errors.
    pub fn from_json(text: &str, file: Option<&str>) -> Result<Preset, PresetError> {
        let with_file = |mut e: PresetError| {
            e.file = file.map(str::to_owned);
            e
        };
        let preset: Preset = serde_json::from_str(text).map_err(|e| {
            // serde_json's message already ends with "at line L column C".
            let what = if e.is_syntax() || e.is_eof() {
                "not valid JSON"
            } else {
                "not a Tactus preset"
            };
            with_file(err("(json)", format!("{what}: {e}")))
        })?;
        preset.validate().map_err(with_file)?;
        Ok(preset)
    }

    /// Reads, parses and validates a preset file.
    pub fn load(path: &Path) -> Result<Preset, PresetError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| PresetError {
            file: Some(name.clone()),
            field: "(file)".into(),
            reason: format!("cannot read: {e}"),
        })?;
        Preset::from_json(&text, Some(&name))
    }

    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("preset serialises")
    }
}

#[cfg(test)]
mod tests;
