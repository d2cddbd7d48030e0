//! One sustained-contact channel of the engine: a [`SustainedVoice`] force generator driving its
//! own [`ModalBank`] loaded with the current object's modes, with position-dependent timbre
//! (Agarwal et al. 2021 §2.4, docs/model.md §6 "Location-dependent IR") and the scraper's / ball's
//! own IR weighted by η (docs/model.md §1 and §7).
//!
//! Morphing: at each new object three variants of its modes are drawn — variant 0 is the nominal
//! object, variants 1 and 2 perturb every mode's log-frequency and log-gain (different strike
//! points of one object). The contact position walks cyclically through 0 → 1 → 2 → 0 every
//! [`MORPH_SPAN_M`]; each mode's frequency and gain are interpolated *logarithmically* between
//! the two neighbouring variants (Agarwal's morphing, not a cross-fade of waveforms). The bank is
//! re-tuned with `set_modes` (state kept: glides are click-free) only on the engine's
//! housekeeping grid and only while the contact moves, so the per-mode pole computation costs
//! about 1/256 of a transcendental call per mode-sample.

use super::surface::WAVINESS_GRAINS;
use super::trajectory::SMOOTHING_REF_SPEED_M_PER_S;
use super::DEFAULT_GRAIN_M;
use super::{ContactKind, SustainedParams, SustainedVoice};
use crate::engine::dsp::DB_PER_NEPER;
use crate::engine::limits::MAX_DISTRIBUTION_MODES;
use crate::engine::limits::MAX_MODES;
use crate::engine::modal::{ModalBank, ModeParams};
use crate::engine::object::{EngineRng, SampledObject};
use crate::engine::stereo::pan_group;
use crate::engine::Settings;
use rand::{RngExt, SeedableRng};

/// Number of sampled IR variants along the surface.
pub const MORPH_VARIANTS: usize = 3;
/// Distance between two sampled variants, m: 10 cm, the spacing of Agarwal's measured IR grid
/// order of magnitude (a few positions across a plank).
pub const MORPH_SPAN_M: f64 = 0.10;
/// SD of a variant's per-mode frequency offset: 2 % (≈ 34 cents). Why: boundary and thickness
/// irregularities shift modes by a few percent between strike points; more sounds like another
/// object.
pub const MORPH_FREQ_SD: f64 = 0.02;
/// SD of a variant's per-mode level offset, dB: 4 dB. Why: mode amplitudes follow the mode shapes,
/// which change sign across nodes; 4 dB is audible as a timbre drift without nulling modes.
pub const MORPH_LEVEL_SD_DB: f64 = 4.0;
/// The bank is re-tuned when the contact moved more than this since the last tuning, m.
pub const MORPH_MIN_MOVE_M: f64 = 1e-4;
/// Striker modes appended to the object's modes.
pub const STRIKER_MODES: usize = 4;
/// Scraper (a held wooden/plastic stick ~15 cm): fundamental in Hz. Free-free bar ratios below.
pub const SCRAPER_F0_HZ: f64 = 900.0;
/// Free-free Euler–Bernoulli bar mode ratios.
pub const BAR_RATIOS: [f64; STRIKER_MODES] = [1.0, 2.757, 5.404, 8.933];
/// Held scraper decay, dB/s: 1500 dB/s (T60 = 40 ms), the hand damps it strongly (Traer et al.
/// leave the scraper out for that reason). Why not less: at 150 dB/s the stick's four modes,
/// weighted by η up to 0.9 of the object's strongest mode, rang longer than most objects' modes
/// and gave every scrape the stick's spectrum.
pub const SCRAPER_DECAY_DB_PER_S: f64 = 1500.0;
/// Ball fundamental × radius, Hz·m: lowest spheroidal mode of a solid sphere, f ≈ 0.85·c_s/(2πR)
/// with shear speed c_s ≈ 3200 m/s (steel, glass): 2 cm → 21.6 kHz, 10 cm → 4.3 kHz.
pub const BALL_F0_HZ_M: f64 = 433.0;
/// Approximate ratios of the next spheroidal modes of a solid sphere.
pub const SPHERE_RATIOS: [f64; STRIKER_MODES] = [1.0, 1.54, 2.03, 2.5];
/// Ball decay, dB/s (a hard ball rings; its support damps it).
pub const BALL_DECAY_DB_PER_S: f64 = 40.0;
/// η of the hand-held scraper: 0.05. Why: the hand damps the stick and the object is what a
/// listener hears through it (Traer et al. leave the scraper out); weighted like a ball, by the
/// object's decay (up to 0.9 of its strongest mode), the stick outweighed ringing objects whose
/// modes lie above its 900 Hz fundamental and gave their scrapes its spectrum.
pub const SCRAPER_ETA: f64 = 0.05;
/// η reference decay, dB/s: η = d/(d + D_REF) with d the object's mean decay — a ringing object
/// (metal, d ≈ 10 dB/s) is heard almost alone, a damped floor (d ≫ 100) mostly as the striker.
pub const ETA_REF_DECAY_DB_PER_S: f64 = 100.0;

/// The per-object mode offsets of the morph variants (log-frequency, log-gain in nepers).
#[derive(Debug, Clone)]
pub struct MorphVariants {
    dlnf: Vec<f64>,
    dlng: Vec<f64>,
}

impl MorphVariants {
    /// Allocates for [`MAX_MODES`] modes (all variants nominal).
    pub fn new() -> Self {
        Self {
            dlnf: vec![0.0; MORPH_VARIANTS * MAX_MODES],
            dlng: vec![0.0; MORPH_VARIANTS * MAX_MODES],
        }
    }

    /// Draws variants 1.. for an object with `seed` (variant 0 stays nominal). Never allocates.
    ///
    /// The offsets of the first [`MAX_DISTRIBUTION_MODES`] modes are drawn first, variant by
    /// variant, and those of the modes beyond (dense fields) after them: the variants of an
    /// object with fewer modes do not depend on how far [`MAX_MODES`] reaches.
    pub fn draw(&mut self, seed: u64) {
        let mut rng = EngineRng::seed_from_u64(seed ^ 0x6D6F_7270_6800_0001);
        let level_np = MORPH_LEVEL_SD_DB / DB_PER_NEPER;
        let first = MAX_DISTRIBUTION_MODES.min(MAX_MODES);
        for (v, m) in (0..MORPH_VARIANTS)
            .flat_map(|v| (0..first).map(move |m| (v, m)))
            .chain((0..MORPH_VARIANTS).flat_map(|v| (first..MAX_MODES).map(move |m| (v, m))))
        {
            let (a, b) = if v == 0 {
                (0.0, 0.0)
            } else {
                (gauss(&mut rng) * MORPH_FREQ_SD, gauss(&mut rng) * level_np)
            };
            self.dlnf[v * MAX_MODES + m] = a;
            self.dlng[v * MAX_MODES + m] = b;
        }
    }

    /// Log-frequency and log-gain offsets of mode `m` at morph coordinate `pos_m`.
    #[inline]
    pub fn offsets(&self, m: usize, pos_m: f64) -> (f64, f64) {
        let phase = (pos_m / MORPH_SPAN_M).rem_euclid(MORPH_VARIANTS as f64);
        let i0 = (phase as usize).min(MORPH_VARIANTS - 1);
        let i1 = (i0 + 1) % MORPH_VARIANTS;
        let w = phase - i0 as f64;
        let (a, b) = (i0 * MAX_MODES + m, i1 * MAX_MODES + m);
        (
            (1.0 - w) * self.dlnf[a] + w * self.dlnf[b],
            (1.0 - w) * self.dlng[a] + w * self.dlng[b],
        )
    }
}

impl Default for MorphVariants {
    fn default() -> Self {
        Self::new()
    }
}

/// Standard normal by Box–Muller (two uniforms; deterministic for a seeded rng).
fn gauss(rng: &mut EngineRng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// What the channel's modes depend on; the bank is re-tuned only when this changes (or while
/// the contact moves with morphing on).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModesKey {
    /// Incremented by the engine at every new object / material.
    pub object_gen: u64,
    /// Frequency scale (1/size).
    pub freq_scale: f64,
    /// Decay multiplier.
    pub damping: f64,
    /// Culling threshold, dB.
    pub quality_db: f64,
    /// Ablation: no striker IR.
    pub surface_ir_only: bool,
    /// Ablation: position morphing on.
    pub morphing: bool,
    /// Ball radius (roll) in m; 0 for the scraper.
    pub radius_m: f64,
}

impl ModesKey {
    /// The key of a channel's modes under `settings` for object generation `object_gen` and
    /// ball radius `radius_m` (0 for the scraper).
    pub fn new(object_gen: u64, settings: &Settings, radius_m: f64) -> Self {
        Self {
            object_gen,
            freq_scale: 1.0 / settings.impact.size,
            damping: settings.impact.damping,
            quality_db: settings.output.quality_db,
            surface_ir_only: settings.ablation.surface_ir_only,
            morphing: settings.ablation.morphing,
            radius_m,
        }
    }
}

/// One scrape or roll channel: force generator + its own bank.
#[derive(Debug, Clone)]
pub struct ContactChannel {
    /// The force generator.
    pub voice: SustainedVoice,
    bank: ModalBank,
    kind: ContactKind,
    awake: bool,
    live: bool,
    inputs_live: bool,
    /// Largest |force| (N) of the last `process` call.
    force_peak_n: f32,
    key: Option<ModesKey>,
    tuned_pos_m: f64,
    modes: Vec<ModeParams>,
    /// Pan group of each entry of `modes` (the striker's at the centre).
    pans: Vec<u8>,
    /// Seed of the object the modes come from: the key of its pan draw.
    pan_seed: u64,
    impulse: Vec<f32>,
    /// The object's level calibration (see [`level_scale`]), applied to the force.
    level_scale: f32,
    /// Contact stiffness of the current object's preset, N/m (the reference impact's contact).
    contact_stiffness_n_per_m: f64,
}

/// Impulse of the reference impact the contact level is calibrated against, N·s: the default
/// striker (50 g) at 1 m/s with an elastic contact, `2·m·v`.
pub const REF_IMPACT_IMPULSE_NS: f64 = 0.1;
/// Striker mass of the reference impact, kg (the default `impact.mass_kg`).
pub const REF_IMPACT_MASS_KG: f64 = 0.05;
/// Window of the reference impact's mean power, s (its first half second: what a listener
/// compares a sustained sound with).
pub const REF_IMPACT_WINDOW_S: f64 = 0.5;
/// Reference force PSD of the scraping channel, N²/Hz (one-sided, in the flat part of its
/// spectrum): see [`scrape_ref_weight`].
pub const SCRAPE_REF_PSD_N2_PER_HZ: f64 = 8.2e-6;
/// Reference force PSD of the rolling channel, N²/Hz: see [`roll_ref_weight`].
pub const ROLL_REF_PSD_N2_PER_HZ: f64 = 9.2e-3;
/// Waviness corner of both reference contacts, Hz: the surface's height spectrum is flat at
/// wavelengths above [`WAVINESS_GRAINS`] grains, so the force (the curvature, `∝ k²·z`) falls
/// as `f⁴` in power below `v / (WAVINESS_GRAINS·grain)`: 156 Hz at 0.5 m/s with 50 µm grains.
pub const REF_WAVINESS_HZ: f64 = SMOOTHING_REF_SPEED_M_PER_S / (WAVINESS_GRAINS * DEFAULT_GRAIN_M);
/// Gaussian corner of the reference scraping force, Hz: above the flat band the default
/// scrape's force (0.5 m/s, 5 N) falls as `exp(−(f/f_s)²)` (the tip's Gaussian smoothing and
/// the grain's roll-off), measured −3.8, −10.0, −16.6 dB at 2, 3, 4 kHz (docs/model.md §9).
pub const SCRAPE_REF_SMOOTHING_HZ: f64 = 2_000.0;
/// Floor of the reference scraping force relative to its flat band: −43 dB, where the measured
/// force levels off (6–16 kHz: the curvature limit's clipping). Without it an object whose
/// modes all lie above the band would be calibrated against a force that does not exist there.
pub const SCRAPE_REF_FLOOR: f64 = 5.0e-5;
/// Corner of the reference rolling force spectrum, Hz: the default ball's (2 cm, 2 N, 0.5 m/s)
/// Hertzian patch low-pass, weighted `1/(1 + (f/f_c)⁴)`.
pub const ROLL_REF_CORNER_HZ: f64 = 600.0;

/// `(f²/(f² + f_w²))²`: the force's fall below the surface's waviness corner
/// [`REF_WAVINESS_HZ`].
#[inline]
fn waviness_weight(freq_hz: f64) -> f64 {
    let f2 = freq_hz * freq_hz;
    let x = f2 / (f2 + REF_WAVINESS_HZ * REF_WAVINESS_HZ);
    x * x
}

/// Shape of the default scrape's force spectrum relative to [`SCRAPE_REF_PSD_N2_PER_HZ`]:
/// waviness high-pass, Gaussian smoothing, floor. `patch_scale` is the tip's patch width
/// relative to the reference contact's ([`super::patch_scale`]): the smoothing is a Gaussian in
/// space, so its corner moves as `1/patch_scale`.
pub fn scrape_ref_weight(freq_hz: f64, patch_scale: f64) -> f64 {
    // The corner combines the tip's Gaussian and the grain's (`v/grain`, which does not move
    // with the patch): `1/f_s² = 1/f_tip² + 1/f_grain²`; only the tip's part scales.
    let inv_grain2 = (DEFAULT_GRAIN_M / SMOOTHING_REF_SPEED_M_PER_S).powi(2);
    let inv_tip2 = (SCRAPE_REF_SMOOTHING_HZ.powi(-2) - inv_grain2).max(0.0);
    let inv_corner2 = patch_scale * patch_scale * inv_tip2 + inv_grain2;
    let smooth = (-freq_hz * freq_hz * inv_corner2).exp();
    waviness_weight(freq_hz) * smooth.max(SCRAPE_REF_FLOOR)
}

/// Shape of the default roll's force spectrum relative to [`ROLL_REF_PSD_N2_PER_HZ`]: waviness
/// high-pass, the patch's fourth-order low-pass, whose corner moves as `1/patch_scale` (the
/// ball's patch width relative to the reference contact's, [`super::patch_scale`]).
pub fn roll_ref_weight(freq_hz: f64, patch_scale: f64) -> f64 {
    waviness_weight(freq_hz) / (1.0 + (freq_hz * patch_scale / ROLL_REF_CORNER_HZ).powi(4))
}

/// Power spectrum of the reference impact's force relative to an ideal impulse of the same
/// impulse, at `freq_hz`, on an object of contact stiffness `stiffness_n_per_m`: the default
/// striker on the default (spring) contact presses a half sine of duration `τ = π·√(m/k)`,
/// `|F(f)|/J = |cos(π·f·τ)| / |1 − (2·f·τ)²|` (docs/model.md §5).
pub fn ref_impact_spectrum(freq_hz: f64, stiffness_n_per_m: f64) -> f64 {
    if !(stiffness_n_per_m > 0.0 && stiffness_n_per_m.is_finite()) {
        return 1.0;
    }
    let tau = std::f64::consts::PI * (REF_IMPACT_MASS_KG / stiffness_n_per_m).sqrt();
    let x = 2.0 * freq_hz * tau;
    let den = 1.0 - x * x;
    // At 2fτ = 1 both vanish; the limit is π/4.
    let a = if den.abs() < 1e-9 {
        std::f64::consts::FRAC_PI_4
    } else {
        (std::f64::consts::PI * freq_hz * tau).cos() / den
    };
    a * a
}

/// Mean power of one mode's reference impact over its first [`REF_IMPACT_WINDOW_S`], for a mode
/// `g·e^{−dt}·cos ωt` per N·s (`freq_hz`, `decay_db_per_s`, `gain`); 0 above `nyquist_hz`.
pub fn ref_impact_power(
    freq_hz: f64,
    decay_db_per_s: f64,
    gain: f64,
    stiffness_n_per_m: f64,
    nyquist_hz: f64,
) -> f64 {
    if !(freq_hz > 0.0 && freq_hz < nyquist_hz) || !gain.is_finite() {
        return 0.0;
    }
    let t = REF_IMPACT_WINDOW_S;
    let d = np_per_s(decay_db_per_s);
    let j2 = REF_IMPACT_IMPULSE_NS * REF_IMPACT_IMPULSE_NS * ref_impact_spectrum(freq_hz, stiffness_n_per_m);
    gain * gain * j2 * (1.0 - (-2.0 * d * t).exp()) / (4.0 * d * t)
}

/// Mean power a force of one-sided PSD `ref_psd_n2_per_hz·weight(f)` (N²/Hz) drives through
/// `modes` (0 above `nyquist_hz`).
pub fn ref_contact_power(
    modes: &[ModeParams],
    ref_psd_n2_per_hz: f64,
    weight: impl Fn(f64) -> f64,
    nyquist_hz: f64,
) -> f64 {
    modes
        .iter()
        .filter(|m| m.freq_hz > 0.0 && m.freq_hz < nyquist_hz && m.gain.is_finite())
        .map(|m| m.gain * m.gain * ref_psd_n2_per_hz * weight(m.freq_hz) / (8.0 * np_per_s(m.decay_db_per_s)))
        .sum()
}

/// Amplitude decay in Np/s from dB/s; a floor of 0.01 Np/s keeps undamped modes (damping 0)
/// finite.
fn np_per_s(decay_db_per_s: f64) -> f64 {
    (decay_db_per_s / DB_PER_NEPER).max(0.01)
}

/// The factor on a contact channel's force that makes it drive the object to the mean power
/// `impact_power` of the reference impact ([`REF_IMPACT_IMPULSE_NS`] through the default
/// contact, [`ref_impact_power`] summed over the object's modes) over its first
/// [`REF_IMPACT_WINDOW_S`], given the power `contact_power` its reference force drives
/// ([`ref_contact_power`]).
///
/// Why: both go through the same modes, but an impact's power over a fixed window saturates
/// for slowly decaying modes (`∝ (1 − e^{−2dT})/(4dT)`) while a sustained force builds them up
/// without bound (`∝ 1/(8d)`, d in Np/s, mode `g·e^{−dt}·cos ωt`). Without the calibration a
/// ringing object's scrape is tens of dB louder relative to its hits than a damped one's, and
/// the preset's absolute level decides the rest. With it, a default scrape and roll sit at the
/// level of a default hit on any object, while speed, pressure, roughness and the force's
/// spectrum (which modes it reaches) still set level and timbre, and the object's modes still
/// shape the spectrum. Never allocates.
pub fn level_scale(impact_power: f64, contact_power: f64) -> f64 {
    if contact_power > 0.0 && impact_power > 0.0 {
        (impact_power / contact_power).sqrt()
    } else {
        1.0
    }
}

impl ContactChannel {
    /// A channel of `kind` (allocates: surface table, mode scratch).
    pub fn new(kind: ContactKind, sample_rate_hz: f64, seed: u64) -> Self {
        Self {
            voice: SustainedVoice::new(sample_rate_hz, seed),
            bank: ModalBank::with_capacity(MAX_MODES + STRIKER_MODES),
            kind,
            awake: false,
            live: false,
            inputs_live: false,
            force_peak_n: 0.0,
            key: None,
            tuned_pos_m: 0.0,
            modes: Vec::with_capacity(MAX_MODES + STRIKER_MODES),
            pans: Vec::with_capacity(MAX_MODES + STRIKER_MODES),
            pan_seed: 0,
            impulse: Vec::new(),
            level_scale: 1.0,
            contact_stiffness_n_per_m: 0.0,
        }
    }

    /// Sample rate and maximum chunk length (allocates); resets.
    pub fn prepare(&mut self, sample_rate_hz: f64, max_block: usize) {
        self.voice.prepare(sample_rate_hz);
        self.bank.set_sample_rate(sample_rate_hz);
        self.impulse = vec![0.0; max_block.max(1)];
        self.key = None;
        self.reset();
    }

    /// Silences the channel (never allocates).
    pub fn reset(&mut self) {
        self.voice.reset();
        self.bank.reset();
        self.awake = false;
        self.live = false;
        self.inputs_live = false;
        self.tuned_pos_m = 0.0;
    }

    /// Whether the force generator computed the last chunk.
    pub fn is_live(&self) -> bool {
        self.live
    }

    /// Whether the bank is ringing (not asleep).
    pub fn is_awake(&self) -> bool {
        self.awake
    }

    /// Largest contact force in N of the last `process` call (0 when not in contact).
    pub fn force_peak_n(&self) -> f32 {
        self.force_peak_n
    }

    /// Active modes of the bank.
    pub fn active_modes(&self) -> usize {
        self.bank.active()
    }

    fn morph_coord(&self) -> f64 {
        let (x, y) = self.voice.position_m();
        x + y
    }

    /// Re-tunes the bank if `key` changed; `contact_stiffness_n_per_m` is the preset's (the
    /// reference impact's contact, see [`ref_impact_spectrum`]), `material_class` the preset's
    /// (it sets the tip's or ball's contact modulus, [`super::contact_modulus_pa`], only when
    /// the bank re-tunes), `pan_seed` the object's seed (its modes' pans,
    /// [`crate::engine::stereo::pan_group`]). Never allocates.
    pub fn update_modes(
        &mut self,
        key: ModesKey,
        object: &SampledObject,
        variants: &MorphVariants,
        contact_stiffness_n_per_m: f64,
        material_class: &str,
        pan_seed: u64,
    ) {
        if self.key != Some(key) {
            self.key = Some(key);
            self.contact_stiffness_n_per_m = contact_stiffness_n_per_m;
            self.voice
                .set_contact_modulus(super::contact_modulus_pa(material_class));
            self.pan_seed = pan_seed;
            let pos = if key.morphing { self.morph_coord() } else { 0.0 };
            self.load(object, variants, pos);
        }
    }

    /// On the housekeeping grid: morph while moving, sleep when silent. Never allocates.
    pub fn housekeeping(&mut self, object: &SampledObject, variants: &MorphVariants, sleep_floor: f32) {
        if let Some(key) = self.key {
            if self.live && key.morphing {
                let pos = self.morph_coord();
                if (pos - self.tuned_pos_m).abs() > MORPH_MIN_MOVE_M {
                    self.load(object, variants, pos);
                }
            }
        }
        if self.awake && !self.live {
            let bound = (self.bank.energy() * self.bank.active() as f32).sqrt();
            if !(bound >= sleep_floor) {
                self.awake = false;
                self.bank.reset();
            }
        }
    }

    fn load(&mut self, object: &SampledObject, variants: &MorphVariants, pos_m: f64) {
        let Some(key) = self.key else { return };
        self.tuned_pos_m = pos_m;
        self.modes.clear();
        self.pans.clear();
        let strongest = object
            .modes
            .iter()
            .map(|m| m.level_db)
            .fold(f64::NEG_INFINITY, f64::max);
        let nyquist = 0.5 * self.voice.sample_rate();
        let mut decay_sum = 0.0;
        let mut impact_power = 0.0;
        for (i, m) in object.modes.iter().enumerate() {
            decay_sum += m.decay_db_per_s * key.damping;
            if m.level_db < strongest - key.quality_db {
                continue;
            }
            let (dlnf, dlng) = if key.morphing {
                variants.offsets(i, pos_m)
            } else {
                (0.0, 0.0)
            };
            let (freq_hz, decay_db_per_s, gain) = (
                m.freq_hz * key.freq_scale,
                m.decay_db_per_s * key.damping,
                10f64.powf(m.level_db / 20.0),
            );
            // The reference hit is the object's own, at its nominal strike point: the morph
            // moves the timbre (which modes), not the object's level.
            impact_power += ref_impact_power(
                freq_hz,
                decay_db_per_s,
                gain,
                self.contact_stiffness_n_per_m,
                nyquist,
            );
            self.modes.push(ModeParams {
                freq_hz: freq_hz * dlnf.exp(),
                decay_db_per_s,
                gain: gain * dlng.exp(),
            });
            self.pans.push(pan_group(self.pan_seed, i));
        }
        // Calibrated on the object's own modes (not the striker's: they are heard through it).
        let patch = super::patch_scale(self.voice.contact_modulus_pa());
        let contact_power = match self.kind {
            ContactKind::Scrape => ref_contact_power(
                &self.modes,
                SCRAPE_REF_PSD_N2_PER_HZ,
                |f| scrape_ref_weight(f, patch),
                nyquist,
            ),
            ContactKind::Roll => ref_contact_power(
                &self.modes,
                ROLL_REF_PSD_N2_PER_HZ,
                |f| roll_ref_weight(f, patch),
                nyquist,
            ),
        };
        self.level_scale = level_scale(impact_power, contact_power) as f32;
        if !key.surface_ir_only && !object.modes.is_empty() {
            let d = decay_sum / object.modes.len() as f64;
            let eta = match self.kind {
                ContactKind::Scrape => SCRAPER_ETA,
                ContactKind::Roll => (d / (d + ETA_REF_DECAY_DB_PER_S)).clamp(0.05, 0.9),
            };
            let g = eta * 10f64.powf(strongest / 20.0);
            let (f0, ratios, decay) = match self.kind {
                ContactKind::Scrape => (SCRAPER_F0_HZ, BAR_RATIOS, SCRAPER_DECAY_DB_PER_S),
                ContactKind::Roll => (
                    BALL_F0_HZ_M / key.radius_m.max(1e-3),
                    SPHERE_RATIOS,
                    BALL_DECAY_DB_PER_S,
                ),
            };
            for r in ratios {
                self.modes.push(ModeParams {
                    freq_hz: f0 * r,
                    decay_db_per_s: decay,
                    gain: g,
                });
            }
        }
        // The striker's modes have no pan entry: they sound at the centre.
        self.bank.set_modes_panned(&self.modes, &self.pans);
    }

    /// Renders one chunk, adding to `out` (the mid, [`ModalBank::process_stereo`]) and, when
    /// given, the side to `side`. Returns (force samples, mode samples) computed.
    /// `speed` (m/s per sample) overrides the params' speed for manual scraping and rolling.
    /// Never allocates, locks or panics.
    pub fn process(
        &mut self,
        p: &SustainedParams,
        speed: Option<&[f32]>,
        out: &mut [f32],
        side: Option<&mut [f32]>,
    ) -> (u64, u64) {
        let n = out.len().min(self.impulse.len());
        let out = &mut out[..n];
        // A preset motion starts from its beginning whenever its inputs become non-zero.
        let inputs_live = p.pressure_n > 0.0 && p.scrape_speed_m_per_s != 0.0;
        if self.kind == ContactKind::Scrape
            && p.motion != super::MotionKind::Manual
            && inputs_live
            && !self.inputs_live
        {
            self.voice.restart();
        }
        self.inputs_live = inputs_live;
        let imp = &mut self.impulse[..n];
        let forced = self.voice.process(p, speed, imp);
        self.live = forced;
        let mut force_samples = 0;
        self.force_peak_n = 0.0;
        if forced {
            force_samples = n as u64;
            // Impulse per sample (N·s) × fs = the sample's mean force.
            let peak = imp.iter().fold(0.0f32, |m, x| m.max(x.abs()));
            self.force_peak_n = peak * self.voice.sample_rate() as f32;
            let k = self.level_scale;
            imp.iter_mut().for_each(|x| *x *= k);
            self.awake = true;
        }
        if !self.awake {
            return (force_samples, 0);
        }
        let input = if forced { Some(&imp[..]) } else { None };
        match side {
            Some(side) => self.bank.process_stereo(input, out, &mut side[..n]),
            None => self.bank.process(input, out),
        }
        (force_samples, (self.bank.active() * n) as u64)
    }
}
