//! The Tactus DSP engine: contact forces driving a modal resonator bank plus a noise-band
//! transient (docs/model.md §1). No plugin or GUI types here: the plugin, the CLI renderer, the tests
//! and the benchmarks all drive [`Engine`] through plain [`Settings`] snapshots and [`Event`]s.
//!
//! Lifecycle (STYLE.md): [`Engine::new`] / [`Engine::prepare`] allocate; [`Engine::reset`] and
//! [`Engine::process`] never allocate, lock or panic, and always write finite samples.

pub mod force;
pub mod materials;
pub mod modal;
pub mod object;
pub mod reference;
pub mod sustained;
pub mod transient;

use force::{ContactModel, ImpactForce, ImpactParams};
use modal::{Maskers, ModalBank, ModeParams};
use object::{perturb_levels, EngineRng, ObjectSampler, SampledObject, MAX_BANDS, MAX_MODES};
use rand::SeedableRng;
use sustained::channel::{ContactChannel, ModesKey, MorphVariants};
use sustained::{ContactKind, MotionKind, SustainedParams};
use transient::TransientBank;

use crate::preset::Preset;

/// Default voice cap.
pub const DEFAULT_MAX_VOICES: usize = 64;

/// A voice sleeps when its output bound falls below this (−110 dBFS).
pub const SLEEP_FLOOR: f32 = 3.162e-6;

/// A single mode is retired when its magnitude falls below this (−130 dBFS): far below the
/// sleep floor, so even a few dozen retired modes together stay inaudible.
pub const MODE_FLOOR: f32 = 3.162e-7;

/// Playback level of digital full scale assumed by the absolute-threshold culling, minus the
/// `quality` setting (dB SPL): at quality 60, 0 dBFS = 110 dB SPL.
pub const PLAYBACK_SPL_OFFSET_DB: f64 = 50.0;

/// Safety margin of the masking culling per dB of `quality` above [`MASKING_MARGIN_FROM_QUALITY`]:
/// the margin is `(quality − 60) / 4` dB, so the default masks at the model's threshold (the
/// MPEG-1 tonal masking index with the steepest, level-independent slopes and each band's
/// farthest point: already a lower bound of the masking threshold), and a higher quality masks
/// less (15 dB margin at 120, 60 dB at 300).
pub const MASKING_MARGIN_PER_QUALITY: f64 = 0.25;

/// The `quality` at and below which the masking margin is 0 dB (the default quality).
pub const MASKING_MARGIN_FROM_QUALITY: f64 = 60.0;

/// The masking margin (dB) at `quality_db`.
pub fn masking_margin_db(quality_db: f64) -> f64 {
    (quality_db - MASKING_MARGIN_FROM_QUALITY).max(0.0) * MASKING_MARGIN_PER_QUALITY
}

/// The masking culling runs at every `MASKING_EVERY`-th housekeeping: masking changes slowly
/// (decays of tens of dB per second) and the pass scans every mode of every voice.
pub const MASKING_EVERY: u64 = 4;

/// Engine time grid (samples) on which modes are retired and voices sleep. Why 256: ~5 ms at
/// 48 kHz, fine enough that decayed modes stop costing promptly, coarse enough that the
/// per-mode magnitude scan is < 1 % of the work it saves.
pub const HOUSEKEEPING_INTERVAL: u64 = 256;

/// Length of the output gain's ramp after a change of `gain_db`: 10 ms. Why: a step in gain
/// on a ringing mode is a click; 10 ms is below the ~20 ms a listener hears as a fade and well
/// inside the 50 ms within which a turned-down gain must have taken effect.
pub const GAIN_RAMP_S: f64 = 0.010;

/// Largest scraping / rolling speed, m/s (per-sample speed buffers are clamped to ± this).
pub const MAX_CONTACT_SPEED: f64 = 10.0;

/// Control values of the engine, in physical units. Filled by the plugin from its parameters
/// once per block, by the CLI from a scene. Out-of-range and non-finite values are clamped by
/// [`Settings::sanitized`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Object scale (1 = the preset's reference object); mode frequencies scale as 1/size.
    pub size: f64,
    /// Decay multiplier, 0..=100: the preset's decays in dB/s are multiplied by this
    /// (1 = as measured, < 1 rings longer, 0 = never decays).
    pub damping: f64,
    /// Striker mass in kg.
    pub mass_kg: f64,
    /// Contact stiffness multiplier on the preset's `contact_stiffness_n_per_m`.
    pub hardness: f64,
    /// Impact contact model.
    pub contact_model: ContactModel,
    /// Re-hit variation: SD of onset-power noise as a fraction of the mean mode power (0.2 = Traer).
    pub variation: f64,
    /// Perceptual culling: modes more than this many dB below the strongest are not computed.
    pub quality_db: f64,
    /// Output gain in dB, applied to everything that sounds (ringing modes, transients, scraping,
    /// rolling) after the synthesis, ramped over [`GAIN_RAMP_S`] so changes never click.
    pub gain_db: f64,
    /// Scraping speed in m/s, 0..=10 (peak speed of a preset motion; manual speed when no
    /// per-sample buffer is given). 0 = no scraping.
    pub scrape_speed_m_per_s: f64,
    /// Scraping motion (docs/model.md §6).
    pub scrape_motion: MotionKind,
    /// Mean normal force of the scraper in N, 0..=1000. 0 = no scraping.
    pub scrape_pressure_n: f64,
    /// Surface roughness 0..=1 (RMS height 0..10 µm), shared by scraping and rolling.
    pub roughness: f64,
    /// Ball centre speed in m/s, 0..=10. 0 = no rolling.
    pub roll_speed_m_per_s: f64,
    /// Ball mean radius in m, 0.001..=1.
    pub roll_radius_m: f64,
    /// Ball centre-of-mass offset r/R, 0..=0.5.
    pub roll_eccentricity: f64,
    /// Ball weight (mean normal force) in N, 0..=1000.
    pub roll_pressure_n: f64,
    /// The paper's comparison switches.
    pub ablation: Ablation,
}

/// Ablation switches of the sustained-contact model (Agarwal et al. 2021's comparisons).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ablation {
    /// tanh curvature limit + Gaussian smoothing of the trajectory (eq. 4–5).
    pub curvature_limit: bool,
    /// Normal force varying with the motion / ball rotation (else held at the mean).
    pub varying_normal_force: bool,
    /// Only the surface's IR (no scraper / ball IR weighted by η).
    pub surface_ir_only: bool,
    /// Position-dependent IR morphing (§2.4).
    pub morphing: bool,
}

impl Default for Ablation {
    fn default() -> Self {
        Self {
            curvature_limit: true,
            varying_normal_force: true,
            surface_ir_only: false,
            morphing: true,
        }
    }
}

/// Per-sample speed inputs of [`Engine::process_with_speed`] (m/s, one value per sample of the
/// block; shorter buffers count as 0 past their end).
#[derive(Debug, Clone, Copy, Default)]
pub struct SpeedInput<'a> {
    /// Scraping speed (signed) for [`MotionKind::Manual`]; preset motions use the settings'
    /// constant peak speed.
    pub scrape_m_per_s: Option<&'a [f32]>,
    /// Ball speed for rolling.
    pub roll_m_per_s: Option<&'a [f32]>,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            size: 1.0,
            damping: 1.0,
            mass_kg: 0.05,
            hardness: 1.0,
            contact_model: ContactModel::Spring,
            variation: 0.2,
            quality_db: 60.0,
            gain_db: 0.0,
            scrape_speed_m_per_s: 0.0,
            scrape_motion: MotionKind::Manual,
            scrape_pressure_n: 5.0,
            roughness: 0.5,
            roll_speed_m_per_s: 0.0,
            roll_radius_m: 0.02,
            roll_eccentricity: 0.1,
            roll_pressure_n: 2.0,
            ablation: Ablation::default(),
        }
    }
}

fn clamp_finite(v: f64, lo: f64, hi: f64, fallback: f64) -> f64 {
    if v.is_finite() {
        v.clamp(lo, hi)
    } else {
        fallback
    }
}

impl Settings {
    /// Every field clamped to its engine range; non-finite values replaced by the default.
    pub fn sanitized(&self) -> Settings {
        let d = Settings::default();
        Settings {
            size: clamp_finite(self.size, 0.01, 100.0, d.size),
            damping: clamp_finite(self.damping, 0.0, 100.0, d.damping),
            mass_kg: clamp_finite(self.mass_kg, 1e-6, 1e3, d.mass_kg),
            hardness: clamp_finite(self.hardness, 1e-4, 1e4, d.hardness),
            contact_model: self.contact_model,
            variation: clamp_finite(self.variation, 0.0, 2.0, d.variation),
            quality_db: clamp_finite(self.quality_db, 1.0, 300.0, d.quality_db),
            gain_db: clamp_finite(self.gain_db, -120.0, 24.0, d.gain_db),
            scrape_speed_m_per_s: clamp_finite(self.scrape_speed_m_per_s, 0.0, MAX_CONTACT_SPEED, 0.0),
            scrape_motion: self.scrape_motion,
            scrape_pressure_n: clamp_finite(self.scrape_pressure_n, 0.0, 1_000.0, 0.0),
            roughness: clamp_finite(self.roughness, 0.0, 1.0, d.roughness),
            roll_speed_m_per_s: clamp_finite(self.roll_speed_m_per_s, 0.0, MAX_CONTACT_SPEED, 0.0),
            roll_radius_m: clamp_finite(self.roll_radius_m, 0.001, 1.0, d.roll_radius_m),
            roll_eccentricity: clamp_finite(self.roll_eccentricity, 0.0, 0.5, d.roll_eccentricity),
            roll_pressure_n: clamp_finite(self.roll_pressure_n, 0.0, 1_000.0, 0.0),
            ablation: self.ablation,
        }
    }
}

/// Something that happens at a sample offset inside the current block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// An impact.
    Impact {
        /// Sample offset inside the block.
        offset: u32,
        /// Impact speed, m/s.
        velocity_m_per_s: f64,
        /// Extra frequency factor for this hit (e.g. from a MIDI note), 1 = none.
        pitch_factor: f64,
        /// Identifier for choking (e.g. MIDI key), or −1.
        key: i32,
    },
    /// Silence the voices started with this key (−1: all).
    Choke {
        /// Sample offset inside the block.
        offset: u32,
        /// Key to choke.
        key: i32,
    },
    /// Draw a new object from the material's distribution with this seed.
    NewObject {
        /// Sample offset inside the block.
        offset: u32,
        /// Seed of the new object.
        seed: u64,
    },
}

impl Event {
    /// Sample offset inside the block.
    pub fn offset(&self) -> u32 {
        match *self {
            Event::Impact { offset, .. } | Event::Choke { offset, .. } | Event::NewObject { offset, .. } => {
                offset
            }
        }
    }
}

/// Work counters, for benchmarks and the "skip what isn't needed" measurements.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Mode-samples computed by the banks.
    pub mode_samples: u64,
    /// Band-samples computed by transients.
    pub band_samples: u64,
    /// Samples during which a contact force was computed.
    pub force_samples: u64,
    /// Voice-blocks processed (active voices × blocks).
    pub voice_blocks: u64,
    /// Blocks that took the idle fast path of [`Engine::process_with_speed`].
    pub idle_blocks: u64,
}

#[derive(Debug, Clone)]
struct Voice {
    bank: ModalBank,
    transient: TransientBank,
    force: ImpactForce,
    active: bool,
    key: i32,
    /// Age in samples, to steal the oldest among equally quiet voices.
    age: u64,
    /// Output bound from the last block, for stealing and sleeping.
    level: f32,
    /// What the voice's modes were tuned from: object generation, frequency scale and damping
    /// (bits). A re-hit with the same tuning and key re-excites this voice's modes instead of
    /// starting new copies of them (see [`Engine::set_merging_enabled`]).
    tuning: [u64; 3],
}

impl Voice {
    fn new() -> Self {
        Self {
            bank: ModalBank::with_capacity(MAX_MODES),
            transient: TransientBank::with_capacity(MAX_BANDS),
            force: ImpactForce::default(),
            active: false,
            key: -1,
            age: 0,
            level: 0.0,
            tuning: [u64::MAX; 3],
        }
    }
}

/// The synthesis engine: one material, one current object, a pool of voices.
pub struct Engine {
    sample_rate: f64,
    max_block: usize,
    samplers: Vec<ObjectSampler>,
    material: usize,
    object: SampledObject,
    object_seed: u64,
    hit_rng: EngineRng,
    voices: Vec<Voice>,
    force_buf: Vec<f32>,
    mono: Vec<f32>,
    levels_db: Vec<f64>,
    modes: Vec<ModeParams>,
    stats: Stats,
    /// Samples rendered since `reset`, for the housekeeping grid.
    time: u64,
    /// Whether impacts start the noise-band transient (benchmark lever; default on).
    transient_enabled: bool,
    /// Largest contact force (N) computed since the last [`Engine::take_force_peak_n`].
    force_peak_n: f32,
    /// False only when no voice is active (cleared by housekeeping, set by every impact): lets
    /// an idle block skip the voice scan.
    any_voice: bool,
    /// [`Engine::is_idle`] at the end of the last block: the idle fast path's one flag.
    idle: bool,
    /// The scene's masking threshold grid, rebuilt by every masking pass (allocated once).
    maskers: Maskers,
    /// Whether modes are culled (static `quality` cut at the hit, dynamic retirement of decayed
    /// and masked modes). Off = every mode below Nyquist runs until its voice sleeps: the
    /// "unculled" reference of the benchmark (default on).
    culling_enabled: bool,
    /// Whether a re-hit of the same object (same tuning and key) re-excites the voice that still
    /// rings from the previous hit instead of stacking a second copy of its modes (default on).
    merging_enabled: bool,
    /// Scratch for merging (capacity `MAX_MODES`, allocated once).
    merge_buf: Vec<ModeParams>,
    merge_used: Vec<bool>,
    /// SIMD variant for the engine's own loops (the banks detect theirs).
    kernel: modal::Kernel,
    /// Sustained-contact channels: scraping and rolling.
    scrape: ContactChannel,
    roll: ContactChannel,
    /// Position-morph variants of the current object.
    variants: MorphVariants,
    /// Incremented at every new object, so the contact banks re-tune.
    object_gen: u64,
    /// Clamped copies of the speed inputs of the current block.
    scrape_speed: Vec<f32>,
    roll_speed: Vec<f32>,
    /// The output gain's ramp (see [`OutputGain`]).
    out_gain: OutputGain,
}

/// The smoothed output gain: a linear ramp (in amplitude) of [`GAIN_RAMP_S`] to each new target.
/// Never allocates.
#[derive(Debug, Clone, Copy)]
struct OutputGain {
    /// Gain now (linear); `None` until the first block, which starts at its target (no fade-in
    /// from an arbitrary gain).
    now: Option<f64>,
    /// Target of the running ramp, dB (a new target restarts the ramp).
    target_db: f64,
    target: f64,
    step: f64,
    left: u64,
}

impl OutputGain {
    fn new() -> Self {
        Self {
            now: None,
            target_db: 0.0,
            target: 1.0,
            step: 0.0,
            left: 0,
        }
    }

    fn set_target(&mut self, gain_db: f64, sample_rate: f64) {
        if self.now.is_some() && gain_db == self.target_db {
            return;
        }
        self.target_db = gain_db;
        self.target = 10f64.powf(gain_db / 20.0);
        match self.now {
            None => {
                self.now = Some(self.target);
                self.left = 0;
            }
            Some(now) => {
                self.left = (GAIN_RAMP_S * sample_rate).round().max(1.0) as u64;
                self.step = (self.target - now) / self.left as f64;
            }
        }
    }

    /// Multiplies `out` by the ramped gain (or only advances the ramp when `out` is silent).
    #[inline]
    fn apply(&mut self, out: &mut [f32], silent: bool) {
        let Some(mut now) = self.now else { return };
        if self.left == 0 {
            if !silent && now != 1.0 {
                let g = now as f32;
                out.iter_mut().for_each(|o| *o *= g);
            }
            return;
        }
        let ramp = (self.left.min(out.len() as u64)) as usize;
        if silent {
            now += self.step * ramp as f64;
        } else {
            for o in &mut out[..ramp] {
                now += self.step;
                *o *= now as f32;
            }
        }
        self.left -= ramp as u64;
        if self.left == 0 {
            now = self.target;
            if !silent {
                let g = now as f32;
                out[ramp..].iter_mut().for_each(|o| *o *= g);
            }
        }
        self.now = Some(now);
    }
}

impl Engine {
    /// An engine for `preset` with at most `max_voices` voices, object drawn with `seed`.
    pub fn new(preset: &Preset, max_voices: usize, seed: u64) -> Self {
        Self::with_library(std::slice::from_ref(preset), 0, max_voices, seed)
    }

    /// An engine that can switch between `presets` in real time (see [`Engine::select_material`]).
    /// `presets` must not be empty.
    pub fn with_library(presets: &[Preset], material: usize, max_voices: usize, seed: u64) -> Self {
        assert!(!presets.is_empty(), "the engine needs at least one material");
        let mut e = Self {
            sample_rate: 48_000.0,
            max_block: 0,
            samplers: presets.iter().map(ObjectSampler::new).collect(),
            material: material.min(presets.len() - 1),
            object: SampledObject::with_capacity(),
            object_seed: seed,
            hit_rng: EngineRng::seed_from_u64(seed ^ 0x5DEECE66D),
            voices: (0..max_voices.max(1)).map(|_| Voice::new()).collect(),
            force_buf: Vec::new(),
            mono: Vec::new(),
            levels_db: vec![0.0; MAX_MODES],
            modes: Vec::with_capacity(MAX_MODES),
            stats: Stats::default(),
            time: 0,
            transient_enabled: true,
            culling_enabled: true,
            merging_enabled: true,
            merge_buf: Vec::with_capacity(MAX_MODES),
            merge_used: vec![false; MAX_MODES],
            kernel: modal::Kernel::detect(),
            any_voice: false,
            idle: true,
            maskers: Maskers::new(),
            force_peak_n: 0.0,
            scrape: ContactChannel::new(ContactKind::Scrape, 48_000.0, seed),
            roll: ContactChannel::new(ContactKind::Roll, 48_000.0, seed ^ 0x0B_A11),
            variants: MorphVariants::new(),
            object_gen: 0,
            scrape_speed: Vec::new(),
            roll_speed: Vec::new(),
            out_gain: OutputGain::new(),
        };
        e.new_object(seed);
        e.prepare(48_000.0, 512);
        e
    }

    /// Allocates for a sample rate and maximum block size. Not real-time safe.
    pub fn prepare(&mut self, sample_rate: f64, max_block: usize) {
        let sample_rate = clamp_finite(sample_rate, 1_000.0, 1_536_000.0, 48_000.0);
        self.sample_rate = sample_rate;
        self.max_block = max_block.max(1);
        self.force_buf = vec![0.0; self.max_block];
        self.mono = vec![0.0; self.max_block];
        self.scrape_speed = vec![0.0; self.max_block];
        self.roll_speed = vec![0.0; self.max_block];
        for v in &mut self.voices {
            v.bank.set_sample_rate(sample_rate);
        }
        self.scrape.prepare(sample_rate, self.max_block);
        self.roll.prepare(sample_rate, self.max_block);
        self.reset();
    }

    /// Replaces material slot `index` (not real-time safe: allocates). Out-of-range indices append.
    pub fn set_material_slot(&mut self, index: usize, preset: &Preset) {
        let sampler = ObjectSampler::new(preset);
        match self.samplers.get_mut(index) {
            Some(s) => *s = sampler,
            None => self.samplers.push(sampler),
        }
    }

    /// Exchanges material slot `index` with `sampler` (real-time safe: no allocation; the previous
    /// sampler ends up in `sampler`, to be dropped off the audio thread). The current object is
    /// kept, even when `index` is the current material: drawing one is too costly for an audio
    /// block, so the caller installs the new material's object ([`Engine::install_object`],
    /// drawn elsewhere) or draws it ([`Engine::draw_object`]). Out-of-range: no-op.
    pub fn swap_material_slot(&mut self, index: usize, sampler: &mut ObjectSampler) {
        if let Some(s) = self.samplers.get_mut(index) {
            std::mem::swap(s, sampler);
        }
    }

    /// Switches to material `index` (clamped) and draws an object with `seed`, if it differs from
    /// the current material. Real-time safe; ringing voices keep their modes.
    pub fn select_material(&mut self, index: usize, seed: u64) {
        let index = index.min(self.samplers.len() - 1);
        if index != self.material {
            self.material = index;
            self.new_object(seed);
        }
    }

    /// Index of the current material.
    pub fn material_index(&self) -> usize {
        self.material
    }

    /// The current material preset.
    pub fn preset(&self) -> &Preset {
        self.samplers[self.material].preset()
    }

    /// Silences all voices. Real-time safe.
    pub fn reset(&mut self) {
        for v in &mut self.voices {
            v.bank.reset();
            v.transient.reset();
            v.force = ImpactForce::default();
            v.active = false;
            v.level = 0.0;
        }
        self.scrape.reset();
        self.roll.reset();
        // Nothing sounds after a reset: the next block starts at its gain without a ramp.
        self.out_gain = OutputGain::new();
        self.maskers.clear_removed();
        self.any_voice = false;
        self.idle = self.is_idle();
        self.time = 0;
        self.hit_rng = EngineRng::seed_from_u64(self.object_seed ^ 0x5DEECE66D);
    }

    /// Draws a new object with `seed` (no allocation, but up to
    /// [`object::MAX_REJECTION_TRIES`] Cholesky products: see [`ObjectSampler::sample`]; ringing
    /// voices keep their modes).
    pub fn new_object(&mut self, seed: u64) {
        let mut rng = EngineRng::seed_from_u64(seed);
        self.samplers[self.material].sample(&mut rng, &mut self.object);
        self.object_installed(seed);
    }

    /// Switches to material `index` (clamped) and draws its object with `seed`, whatever the
    /// current material and seed.
    pub fn draw_object(&mut self, index: usize, seed: u64) {
        self.material = index.min(self.samplers.len() - 1);
        self.new_object(seed);
    }

    /// Makes `object`, drawn elsewhere from material `index` (clamped) with `seed`, the current
    /// object, exactly as [`Engine::draw_object`] would have drawn it; the previous object ends
    /// up in `object`. Real-time safe and cheap: buffers are exchanged, nothing is drawn,
    /// allocated or freed (both objects have [`SampledObject::with_capacity`] storage).
    pub fn install_object(&mut self, index: usize, seed: u64, object: &mut SampledObject) {
        self.material = index.min(self.samplers.len() - 1);
        std::mem::swap(&mut self.object, object);
        self.object_installed(seed);
    }

    /// What follows every new object: the seed, hit RNG, morph variants and re-tuning.
    fn object_installed(&mut self, seed: u64) {
        self.object_seed = seed;
        self.hit_rng = EngineRng::seed_from_u64(seed ^ 0x5DEECE66D);
        self.variants.draw(seed);
        self.object_gen = self.object_gen.wrapping_add(1);
    }

    /// Number of material slots.
    pub fn material_count(&self) -> usize {
        self.samplers.len()
    }

    /// The current object.
    pub fn object(&self) -> &SampledObject {
        &self.object
    }

    /// Seed of the current object.
    pub fn object_seed(&self) -> u64 {
        self.object_seed
    }

    /// Sample rate in Hz.
    pub fn sample_rate(&self) -> f64 {
        self.sample_rate
    }

    /// Enables or disables the impact transient (benchmark and test lever; default enabled).
    pub fn set_transient_enabled(&mut self, enabled: bool) {
        self.transient_enabled = enabled;
    }

    /// Enables or disables mode culling (benchmark and test lever; default enabled): off, every
    /// mode below Nyquist runs until its voice sleeps.
    pub fn set_culling_enabled(&mut self, enabled: bool) {
        self.culling_enabled = enabled;
    }

    /// Enables or disables re-strike merging (benchmark and test lever; default enabled).
    ///
    /// On: an impact on the object a voice still rings from (same object, size, damping and key;
    /// that voice's contact over) adds its excitation to that voice's modes instead of starting
    /// a second voice with copies of the same modes. The bank is linear and the poles are
    /// identical, so the sum of the two copies' states *is* one mode's state: the output is the
    /// same up to f32 rounding, with one set of modes computed instead of one per hit. The old
    /// hit's noise transient, if still sounding, moves to a voice of its own. Off, every hit
    /// takes a voice (the benchmark's "nothing skipped" reference).
    pub fn set_merging_enabled(&mut self, enabled: bool) {
        self.merging_enabled = enabled;
    }

    /// The largest contact force in N (impacts, scraping, rolling; per-sample means) computed
    /// since the previous call, and resets it: the editor's contact-force meter. Never allocates.
    pub fn take_force_peak_n(&mut self) -> f32 {
        let f = self.force_peak_n;
        self.force_peak_n = 0.0;
        if f.is_finite() {
            f
        } else {
            0.0
        }
    }

    /// Work counters since construction or [`Engine::take_stats`].
    pub fn take_stats(&mut self) -> Stats {
        std::mem::take(&mut self.stats)
    }

    /// True when nothing sounds: no voice active and neither contact channel ringing. An idle
    /// engine with no events and zero contact speeds renders silence at the cost of zeroing
    /// the outputs.
    pub fn is_idle(&self) -> bool {
        !self.any_voice && !self.scrape.is_awake() && !self.roll.is_awake()
    }

    /// Number of voices currently sounding.
    pub fn active_voices(&self) -> usize {
        self.voices.iter().filter(|v| v.active).count()
    }

    /// Renders one block into `left`/`right` (overwritten; equal lengths ≤ the prepared maximum,
    /// longer blocks are split). `events` must be sorted by offset; offsets past the block end
    /// are applied at its last sample.
    #[inline]
    pub fn process(&mut self, settings: &Settings, events: &[Event], left: &mut [f32], right: &mut [f32]) {
        self.process_with_speed(settings, events, SpeedInput::default(), left, right);
    }

    /// [`Engine::process`] with per-sample scraping / rolling speeds (automation, scene curves).
    /// Never allocates, locks or panics; always writes finite samples.
    #[inline]
    pub fn process_with_speed(
        &mut self,
        settings: &Settings,
        events: &[Event],
        speed: SpeedInput<'_>,
        left: &mut [f32],
        right: &mut [f32],
    ) {
        let len = left.len().min(right.len());
        // Idle fast path: nothing sounding and nothing that could start (no events, no speed
        // buffers, constant speeds exactly 0; NaN speeds take the full path, which sanitises
        // them). Costs a few comparisons and clearing the outputs (`modal::clear_pair`).
        if events.is_empty()
            && speed.scrape_m_per_s.is_none()
            && speed.roll_m_per_s.is_none()
            && self.idle
            && settings.scrape_speed_m_per_s == 0.0
            && settings.roll_speed_m_per_s == 0.0
        {
            modal::clear_pair(self.kernel, &mut left[..len], &mut right[..len]);
            self.stats.idle_blocks += 1;
            self.out_gain.set_target(
                clamp_finite(settings.gain_db, -120.0, 24.0, 0.0),
                self.sample_rate,
            );
            self.out_gain.apply(&mut left[..len], true);
            self.time += len as u64;
            return;
        }
        self.process_full(settings, events, speed, left, right);
    }

    /// The non-idle part of [`Engine::process_with_speed`], kept out of line so the idle path
    /// (inlined into the caller) does not pay this function's large stack frame.
    #[inline(never)]
    fn process_full(
        &mut self,
        settings: &Settings,
        events: &[Event],
        speed: SpeedInput<'_>,
        left: &mut [f32],
        right: &mut [f32],
    ) {
        let len = left.len().min(right.len());
        let s = settings.sanitized();
        let last = len.saturating_sub(1);
        let mut ev = 0;
        let mut pos = 0;
        loop {
            // Events past the block end apply at its last sample, so none is ever lost.
            while ev < events.len() && (events[ev].offset() as usize).min(last) <= pos {
                self.apply_event(&s, &events[ev]);
                ev += 1;
            }
            if pos >= len {
                break;
            }
            let next = events
                .get(ev)
                .map_or(len, |e| (e.offset() as usize).min(last).max(pos + 1));
            let to_grid = (HOUSEKEEPING_INTERVAL - self.time % HOUSEKEEPING_INTERVAL) as usize;
            let end = next.min(pos + self.max_block).min(pos + to_grid).min(len);
            let has_scrape = self.clamp_speed(speed.scrape_m_per_s, pos, end, true);
            let has_roll = self.clamp_speed(speed.roll_m_per_s, pos, end, false);
            self.render(&s, &mut left[pos..end], has_scrape, has_roll);
            right[pos..end].copy_from_slice(&left[pos..end]);
            pos = end;
        }
        self.idle = self.is_idle();
    }

    /// Copies `input[pos..end]` clamped to ±[`MAX_CONTACT_SPEED`] (non-finite → 0, missing → 0)
    /// into the scrape or roll scratch; returns whether an input was given.
    fn clamp_speed(&mut self, input: Option<&[f32]>, pos: usize, end: usize, scrape: bool) -> bool {
        let Some(input) = input else { return false };
        let buf = if scrape {
            &mut self.scrape_speed
        } else {
            &mut self.roll_speed
        };
        let max = MAX_CONTACT_SPEED as f32;
        for (i, o) in buf[..end - pos].iter_mut().enumerate() {
            let v = input.get(pos + i).copied().unwrap_or(0.0);
            *o = if v.is_finite() { v.clamp(-max, max) } else { 0.0 };
        }
        true
    }

    fn apply_event(&mut self, s: &Settings, e: &Event) {
        match *e {
            Event::Impact {
                velocity_m_per_s,
                pitch_factor,
                key,
                ..
            } => self.start_impact(s, velocity_m_per_s, pitch_factor, key),
            Event::Choke { key, .. } => {
                for v in &mut self.voices {
                    if key < 0 || v.key == key {
                        v.active = false;
                        v.bank.reset();
                        v.transient.reset();
                    }
                }
            }
            Event::NewObject { seed, .. } => self.new_object(seed),
        }
    }

    fn start_impact(&mut self, s: &Settings, velocity: f64, pitch_factor: f64, key: i32) {
        let velocity = clamp_finite(velocity, 0.0, 100.0, 0.0);
        if velocity <= 0.0 {
            return;
        }
        let pitch = clamp_finite(pitch_factor, 1e-3, 1e3, 1.0);
        let n = self.object.modes.len();
        perturb_levels(
            &self.object.modes,
            s.variation,
            &mut self.hit_rng,
            &mut self.levels_db[..n],
        );
        let freq_scale = pitch / s.size;
        let tuning = [self.object_gen, freq_scale.to_bits(), s.damping.to_bits()];
        let strongest = self.levels_db[..n]
            .iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max);
        self.modes.clear();
        for (m, &level) in self.object.modes.iter().zip(&self.levels_db[..n]) {
            if self.culling_enabled && level < strongest - s.quality_db {
                continue;
            }
            self.modes.push(ModeParams {
                freq_hz: m.freq_hz * freq_scale,
                decay_db_per_s: m.decay_db_per_s * s.damping,
                gain: 10f64.powf(level / 20.0),
            });
        }
        // Re-strike: the voice still ringing from an earlier hit of this object (its contact
        // over) takes the new excitation on the same modes.
        let merge_into = if self.merging_enabled {
            self.voices.iter().position(|v| {
                v.active && v.key == key && v.tuning == tuning && v.bank.active() > 0 && !v.force.is_active()
            })
        } else {
            None
        };
        let idx = match merge_into {
            Some(o) => {
                if self.voices[o].transient.active() > 0 {
                    self.move_transient_out(o);
                }
                self.merge_modes(o);
                o
            }
            None => {
                let i = self.free_or_quietest(None);
                let v = &mut self.voices[i];
                v.bank.reset();
                v.bank.set_modes(&self.modes);
                i
            }
        };
        let stiffness = self.preset().contact_stiffness_n_per_m * s.hardness;
        let params = ImpactParams::new(s.mass_kg, velocity, stiffness, s.contact_model);
        let seed = self.hit_rng.next_u32_compat();
        let v = &mut self.voices[idx];
        v.force.start(&params, self.sample_rate);
        // The transient is the part of the IR the contact excites: scale it by the contact's
        // impulse m·v·(1+e) (2·m·v for the lossless models).
        let impulse = v.force.summary().impulse_ns;
        v.transient.reset();
        if self.transient_enabled {
            v.transient.start(
                &self.object.bands,
                impulse,
                v.force.duration_s(),
                freq_scale,
                s.damping,
                self.sample_rate,
                seed,
            );
        }
        v.active = true;
        self.any_voice = true;
        v.key = key;
        v.age = 0;
        v.level = 1.0;
        v.tuning = tuning;
    }

    /// Moves voice `o`'s still-sounding transient to a voice of its own (a free one, else the
    /// quietest other voice), which sounds only that: no modes, no contact. With a single voice
    /// there is nowhere to move it, and the next hit's transient replaces it.
    fn move_transient_out(&mut self, o: usize) {
        let spare = self.free_or_quietest(Some(o));
        if spare == o {
            return;
        }
        let (lo, hi) = self.voices.split_at_mut(o.max(spare));
        let (a, b) = if spare < o {
            (&mut lo[spare], &mut hi[0])
        } else {
            (&mut hi[0], &mut lo[o])
        };
        std::mem::swap(&mut a.transient, &mut b.transient);
        a.bank.set_modes(&[]);
        a.force = ImpactForce::default();
        a.active = true;
        a.key = b.key;
        a.age = 0;
        a.level = 0.0;
        a.tuning = [u64::MAX; 3];
    }

    /// A free voice, else the quietest (oldest among equally quiet), never `except`.
    fn free_or_quietest(&self, except: Option<usize>) -> usize {
        let ok = |i: usize| Some(i) != except;
        if let Some(i) = (0..self.voices.len()).find(|&i| ok(i) && !self.voices[i].active) {
            return i;
        }
        let mut best: Option<usize> = None;
        for (i, v) in self.voices.iter().enumerate().filter(|(i, _)| ok(*i)) {
            let better = match best {
                None => true,
                Some(b) => {
                    let b = &self.voices[b];
                    v.level < b.level || (v.level == b.level && v.age > b.age)
                }
            };
            if better {
                best = Some(i);
            }
        }
        // Only one voice and it is `except`: share it.
        best.unwrap_or(0)
    }

    /// Gives voice `o` the new hit's modes (`self.modes`) while keeping the state of every mode it
    /// still rings with: a mode of both gets the new hit's gain (the gain scales new excitation
    /// only), a mode only the voice has keeps ringing unexcited (gain 0), a mode only the new hit
    /// has starts from rest. Modes are matched on identical frequency and decay (same object and
    /// tuning, so identical poles). Never allocates (`merge_buf` has `MAX_MODES` room, and both
    /// lists are subsets of one object's ≤ `MAX_MODES` modes).
    fn merge_modes(&mut self, o: usize) {
        let new = &self.modes;
        let used = &mut self.merge_used[..new.len()];
        used.fill(false);
        self.merge_buf.clear();
        let bank = &mut self.voices[o].bank;
        for i in 0..bank.active() {
            let Some(m) = bank.mode(i) else { break };
            let hit = new.iter().enumerate().position(|(j, x)| {
                !used[j] && x.freq_hz == m.freq_hz && x.decay_db_per_s == m.decay_db_per_s
            });
            let gain = match hit {
                Some(j) => {
                    used[j] = true;
                    new[j].gain
                }
                None => 0.0,
            };
            self.merge_buf.push(ModeParams { gain, ..m });
        }
        // Kept modes first, in slot order, so each keeps its slot (and state) in `set_modes`.
        for (x, _) in new.iter().zip(used.iter()).filter(|(_, u)| !**u) {
            if self.merge_buf.len() < self.merge_buf.capacity() {
                self.merge_buf.push(*x);
            }
        }
        bank.set_modes(&self.merge_buf);
    }

    /// Retires decayed and culled modes and puts silent voices to sleep. Runs only at multiples of
    /// [`HOUSEKEEPING_INTERVAL`] samples of engine time, so its decisions do not depend on the
    /// host's block size (renders stay block-size independent).
    fn housekeeping(&mut self, s: &Settings) {
        self.scrape
            .housekeeping(&self.object, &self.variants, SLEEP_FLOOR);
        self.roll.housekeeping(&self.object, &self.variants, SLEEP_FLOOR);
        // Dynamic perceptual culling (docs/model.md §8): a free-ringing mode whose magnitude is more
        // than `quality_db` below the voice's strongest mode, or below the per-mode floor, only
        // decays further relative to the others it falls behind: it is retired for good.
        let rel = 10f64.powf(-s.quality_db / 20.0);
        // Absolute threshold: full scale is assumed to play at `PLAYBACK_SPL_OFFSET_DB + quality`
        // dB SPL (110 dB SPL at the default quality 60, louder than any sane monitoring level);
        // a mode below the threshold of hearing at its frequency at that level is inaudible
        // whatever else sounds (docs/model.md §8, Raghuvanshi & Lin's absolute-threshold culling).
        let threshold_scale = 10f64.powf(-(PLAYBACK_SPL_OFFSET_DB + s.quality_db) / 10.0);
        // Simultaneous masking across all voices (docs/model.md §8, `modal::Maskers`): the loudest
        // modes of the scene mask what lies far enough below them and decays at least as fast.
        // Safety margin: a quarter of `quality` above 60 (0 dB at the default; see
        // `MASKING_MARGIN_PER_QUALITY`).
        // The masking pass runs every `MASKING_EVERY`-th housekeeping (21 ms at 48 kHz).
        let masking =
            self.culling_enabled && (self.time / HOUSEKEEPING_INTERVAL).is_multiple_of(MASKING_EVERY);
        if masking {
            self.maskers.begin(
                masking_margin_db(s.quality_db),
                (MASKING_EVERY * HOUSEKEEPING_INTERVAL) as f64 / self.sample_rate,
            );
            for v in self.voices.iter().filter(|v| v.active) {
                v.bank.collect_maskers(&mut self.maskers);
            }
            self.maskers.finish();
        }
        let mut maskers = masking.then_some(&mut self.maskers);
        for v in self.voices.iter_mut().filter(|v| v.active) {
            let excited = v.force.is_active();
            if !excited {
                if self.culling_enabled {
                    let strongest = v.bank.max_energy().sqrt();
                    let floor = (strongest * rel).max(MODE_FLOOR as f64);
                    v.bank
                        .retire_masked(floor, threshold_scale, maskers.as_deref_mut());
                    // The noise bands by the same rules: `quality` dB below the transient's
                    // strongest band (not below the strongest mode: a transient spread over 30
                    // bands, each far below a loud mode, measured up to 4 dB off in one frame
                    // of the metal impact), the −130 dBFS floor and the threshold of hearing (a
                    // band's envelope only falls: below those two it stays inaudible).
                    let band_floor = (v.transient.max_env() * rel as f32).max(MODE_FLOOR);
                    v.transient.cull(band_floor, threshold_scale);
                } else {
                    // Only modes whose state is exactly 0 (flushed) or non-finite.
                    v.bank.retire_below(f32::MIN_POSITIVE);
                }
            }
            // Output bound: |Σ Re z_i| ≤ Σ|z_i| ≤ √(N·Σ|z_i|²) (Cauchy–Schwarz).
            let bound = (v.bank.energy() * v.bank.active() as f32).sqrt();
            v.level = bound;
            if !excited && v.transient.active() == 0 && !(bound >= SLEEP_FLOOR) {
                v.active = false;
                v.bank.reset();
            }
        }
        self.any_voice = self.voices.iter().any(|v| v.active);
    }

    fn render(&mut self, s: &Settings, out: &mut [f32], has_scrape: bool, has_roll: bool) {
        let len = out.len();
        out.iter_mut().for_each(|v| *v = 0.0);
        // Whether anything can write to `out` this chunk; an idle engine skips the output guard.
        let mut wrote = has_scrape || has_roll || self.scrape.is_awake() || self.roll.is_awake();
        // Idle: no voice sounding, no contact ringing and nothing that could start one (no speed
        // buffer, zero constant speeds). Only the clock advances; the contact banks re-tune
        // (`update_modes`) when they next run, and housekeeping has nothing to retire.
        if !wrote
            && !(s.scrape_speed_m_per_s != 0.0)
            && !(s.roll_speed_m_per_s != 0.0)
            && !(self.any_voice && self.voices.iter().any(|v| v.active))
        {
            self.out_gain.set_target(s.gain_db, self.sample_rate);
            self.out_gain.apply(out, true);
            self.time += len as u64;
            return;
        }
        self.render_contacts(s, out, has_scrape, has_roll);
        wrote |= self.scrape.is_awake() || self.roll.is_awake();
        for v in self.voices.iter_mut().filter(|v| v.active) {
            wrote = true;
            self.stats.voice_blocks += 1;
            let force = &mut self.force_buf[..len];
            let forced = v.force.is_active() && v.force.fill(force);
            if forced {
                self.stats.force_samples += len as u64;
                // Impulse per sample (N·s) × fs = the sample's mean force.
                let peak = force.iter().fold(0.0f32, |m, x| m.max(x.abs()));
                self.force_peak_n = self.force_peak_n.max(peak * self.sample_rate as f32);
            }
            v.bank.process(if forced { Some(force) } else { None }, out);
            self.stats.mode_samples += (v.bank.active() * len) as u64;
            self.stats.band_samples += (v.transient.active() * len) as u64;
            v.transient.process(out);
            v.age += len as u64;
        }
        self.time += len as u64;
        if self.time.is_multiple_of(HOUSEKEEPING_INTERVAL) {
            self.housekeeping(s);
        }
        self.out_gain.set_target(s.gain_db, self.sample_rate);
        self.out_gain.apply(out, !wrote);
        if !wrote {
            return;
        }
        // Output is always finite and never subnormal: decaying f64 tails pass through f32's
        // subnormal range when converted (hosts and clap-validator's fuzzer flag those).
        for o in out.iter_mut() {
            if !o.is_finite() || o.abs() < f32::MIN_POSITIVE {
                *o = 0.0;
            }
        }
    }
}

impl Engine {
    /// The scraping and rolling channels (docs/model.md §6–7) for one chunk.
    fn render_contacts(&mut self, s: &Settings, out: &mut [f32], has_scrape: bool, has_roll: bool) {
        let len = out.len();
        let key = ModesKey {
            object_gen: self.object_gen,
            freq_scale: 1.0 / s.size,
            damping: s.damping,
            quality_db: s.quality_db,
            surface_ir_only: s.ablation.surface_ir_only,
            morphing: s.ablation.morphing,
            radius_m: 0.0,
        };
        let base = SustainedParams {
            roughness: s.roughness,
            ..SustainedParams::default()
        };
        let scrape = SustainedParams {
            kind: ContactKind::Scrape,
            motion: s.scrape_motion,
            scrape_speed_m_per_s: if has_scrape && s.scrape_motion == MotionKind::Manual {
                // Liveness comes from the buffer; the constant is unused.
                1.0
            } else {
                s.scrape_speed_m_per_s
            },
            pressure_n: s.scrape_pressure_n,
            ..base
        };
        let roll = SustainedParams {
            kind: ContactKind::Roll,
            roll_speed_m_per_s: s.roll_speed_m_per_s,
            pressure_n: s.roll_pressure_n,
            roll_radius_m: s.roll_radius_m,
            roll_eccentricity: s.roll_eccentricity,
            ..base
        };
        for (ch, p, speed, radius) in [
            (
                &mut self.scrape,
                &scrape,
                has_scrape.then_some(&self.scrape_speed[..len]),
                0.0,
            ),
            (
                &mut self.roll,
                &roll,
                has_roll.then_some(&self.roll_speed[..len]),
                s.roll_radius_m,
            ),
        ] {
            ch.voice.curvature_limit = s.ablation.curvature_limit;
            ch.voice.varying_normal_force = s.ablation.varying_normal_force;
            ch.update_modes(
                ModesKey {
                    radius_m: radius,
                    ..key
                },
                &self.object,
                &self.variants,
            );
            let (f, m) = ch.process(p, speed, out);
            self.force_peak_n = self.force_peak_n.max(ch.force_peak_n());
            self.stats.force_samples += f;
            self.stats.mode_samples += m;
        }
    }

    /// Whether the scraping / rolling force generators computed the last chunk.
    pub fn contacts_live(&self) -> (bool, bool) {
        (self.scrape.is_live(), self.roll.is_live())
    }

    /// Whether the scraping / rolling banks are ringing (not asleep).
    pub fn contacts_awake(&self) -> (bool, bool) {
        (self.scrape.is_awake(), self.roll.is_awake())
    }
}

/// Extension so the engine can draw a `u32` seed without importing rand's traits everywhere.
trait NextU32 {
    fn next_u32_compat(&mut self) -> u32;
}

impl NextU32 for EngineRng {
    fn next_u32_compat(&mut self) -> u32 {
        use rand::Rng;
        self.next_u32()
    }
}
