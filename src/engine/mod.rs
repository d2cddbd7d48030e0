//! The Tactus DSP engine: contact forces driving a modal resonator bank plus a noise-band
//! transient (docs/model.md §1). No plugin or GUI types here: the plugin, the CLI renderer, the tests
//! and the benchmarks all drive [`Engine`] through plain [`Settings`] snapshots and [`Event`]s.
//!
//! [`Engine`] composes named parts (docs/architecture.md): the material library and its current
//! object (`library`), the impact [`voices`], the scraping and rolling contacts (`contacts`), the
//! [`culling`] policy, the output [`gain`] and the benchmark switches ([`EngineOptions`]); its
//! inputs are [`Settings`] and [`Event`]s, its work counters [`Stats`].
//!
//! Lifecycle (STYLE.md): [`Engine::new`] / [`Engine::prepare`] allocate; [`Engine::reset`] and
//! [`Engine::process`] never allocate, lock or panic, and always write finite samples. Every
//! part has the same two lifecycle methods ([`Lifecycle`]), which the engine's forward to.

pub mod bodies;
pub mod catalog;
mod contacts;
pub mod culling;
pub mod dense;
pub mod dsp;
mod event;
pub mod force;
pub mod gain;
pub mod gesture;
mod library;
pub mod limiter;
pub mod limits;
pub mod materials;
pub mod modal;
pub mod object;
mod options;
pub mod reference;
pub mod settings;
mod stats;
pub mod stereo;
pub mod sustained;
pub mod transient;
pub mod voices;

use bodies::BodySet;
use contacts::Contacts;
use culling::Culling;
use force::ImpactParams;
use gain::OutputGain;
use library::Library;
use limits::MAX_MODES;
use modal::{build_up_pair, ring_pair, ModeParams};
use object::{perturb_levels, EngineRng, ObjectSampler, SampledObject};
use rand::SeedableRng;
use settings::clamp_finite;
use stereo::{pan_group, WidthRamp};
use voices::{Strike, Voices};

pub use event::Event;
pub use stats::Stats;

pub use culling::{
    masking_margin_db, MASKING_EVERY, MASKING_MARGIN_FROM_QUALITY, MASKING_MARGIN_PER_QUALITY, MODE_FLOOR,
    PLAYBACK_SPL_OFFSET_DB,
};
pub use gain::GAIN_RAMP_S;
pub use options::EngineOptions;
pub use settings::{Ablation, ImpactSettings, OutputSettings, RollParams, ScrapeParams, Settings};
pub use voices::{DEFAULT_MAX_VOICES, SLEEP_FLOOR};

use crate::preset::Preset;

/// The lifecycle every part of the engine shares (STYLE.md; FunDSP's one lifecycle per node).
pub trait Lifecycle {
    /// Sample rate (Hz) and largest chunk (samples) the part will process. May allocate; not
    /// real-time safe. Followed by [`Lifecycle::reset`] before the next block.
    fn prepare(&mut self, sample_rate_hz: f64, max_block: usize);
    /// Back to silence. Never allocates, locks or panics.
    fn reset(&mut self);
}

/// Engine time grid (samples) on which modes are retired and voices sleep. Why 256: ~5 ms at
/// 48 kHz, fine enough that decayed modes stop costing promptly, coarse enough that the
/// per-mode magnitude scan is < 1 % of the work it saves.
pub const HOUSEKEEPING_INTERVAL: u64 = 256;

pub use limits::MAX_CONTACT_SPEED_M_PER_S as MAX_CONTACT_SPEED;

/// Per-sample speed inputs of [`Engine::process_with_speed`] (m/s, one value per sample of the
/// block; shorter buffers count as 0 past their end).
#[derive(Debug, Clone, Copy, Default)]
pub struct SpeedInput<'a> {
    /// Scraping speed (signed) for [`sustained::MotionKind::Manual`]; preset motions use the settings'
    /// constant peak speed.
    pub scrape_m_per_s: Option<&'a [f32]>,
    /// Ball speed for rolling.
    pub roll_m_per_s: Option<&'a [f32]>,
}

/// The synthesis engine: one material, one current object, a pool of voices, two contact
/// channels.
pub struct Engine {
    sample_rate: f64,
    max_block: usize,
    /// The material slots and the current object.
    library: Library,
    /// Per-hit level variation.
    hit_rng: EngineRng,
    /// Whether the current object has been struck since it was drawn (or since `reset`): its
    /// first hit sounds the drawn levels, later hits perturb them (docs/model.md §3).
    struck: bool,
    /// Scratch of a hit: its perturbed levels and its modes (capacity `MAX_MODES`).
    levels_db: Vec<f64>,
    modes: Vec<ModeParams>,
    /// Pan group of each entry of `modes` (capacity `MAX_MODES`).
    pans: Vec<u8>,
    voices: Voices,
    /// A gesture's other bodies ([`Engine::draw_bodies`]); empty storage until
    /// [`Engine::reserve_bodies`].
    bodies: BodySet,
    /// Changes with every body set, so a hit never merges into a voice of another set's body.
    bodies_generation: u64,
    contacts: Contacts,
    culling: Culling,
    out_gain: OutputGain,
    /// The smoothed stereo width (docs/model.md "Stereo pickups").
    width: WidthRamp,
    options: EngineOptions,
    stats: Stats,
    /// Samples rendered since `reset`, for the housekeeping grid.
    time: u64,
    /// Largest contact force (N) computed since the last [`Engine::take_force_peak_n`].
    force_peak_n: f32,
    /// [`Engine::is_idle`] at the end of the last block: the idle fast path's one flag.
    idle: bool,
    /// SIMD variant for the engine's own loops (the banks detect theirs).
    kernel: modal::Kernel,
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
        Self::with_library_samplers(Library::new(presets, material, seed), max_voices, seed)
    }

    /// As [`Engine::with_library`], from the samplers of the presets (cloned from a cache, say:
    /// building a sampler factors its covariances, the bulk of creating an engine).
    pub fn with_samplers(
        samplers: Vec<ObjectSampler>,
        material: usize,
        max_voices: usize,
        seed: u64,
    ) -> Self {
        assert!(!samplers.is_empty(), "the engine needs at least one material");
        Self::with_library_samplers(Library::with_samplers(samplers, material, seed), max_voices, seed)
    }

    fn with_library_samplers(library: Library, max_voices: usize, seed: u64) -> Self {
        let fs = 48_000.0;
        let mut e = Self {
            sample_rate: fs,
            max_block: 0,
            library,
            hit_rng: EngineRng::seed_from_u64(seed ^ 0x5DEECE66D),
            struck: false,
            levels_db: vec![0.0; MAX_MODES],
            modes: Vec::with_capacity(MAX_MODES),
            pans: Vec::with_capacity(MAX_MODES),
            voices: Voices::new(max_voices, fs),
            bodies: BodySet::default(),
            bodies_generation: 0,
            contacts: Contacts::new(fs, seed),
            culling: Culling::new(fs),
            out_gain: OutputGain::new(fs),
            width: WidthRamp::new(fs),
            options: EngineOptions::default(),
            stats: Stats::default(),
            time: 0,
            force_peak_n: 0.0,
            idle: true,
            kernel: modal::Kernel::detect(),
        };
        e.new_object(seed);
        e.prepare(fs, 512);
        e
    }

    /// The parts with a [`Lifecycle`], which `prepare` and `reset` forward to.
    fn parts(&mut self) -> [&mut dyn Lifecycle; 5] {
        [
            &mut self.voices,
            &mut self.contacts,
            &mut self.culling,
            &mut self.out_gain,
            &mut self.width,
        ]
    }

    /// Allocates for a sample rate and maximum block size, then resets. Not real-time safe.
    pub fn prepare(&mut self, sample_rate: f64, max_block: usize) {
        let sample_rate = clamp_finite(sample_rate, 1_000.0, 1_536_000.0, 48_000.0);
        self.sample_rate = sample_rate;
        self.max_block = max_block.max(1);
        let max_block = self.max_block;
        for part in self.parts() {
            part.prepare(sample_rate, max_block);
        }
        self.reset();
    }

    /// Silences everything. Real-time safe.
    pub fn reset(&mut self) {
        for part in self.parts() {
            part.reset();
        }
        self.idle = self.is_idle();
        self.time = 0;
        self.hit_rng = EngineRng::seed_from_u64(self.library.seed() ^ 0x5DEECE66D);
        self.struck = false;
    }

    /// Replaces material slot `index` (not real-time safe: allocates). Out-of-range indices append.
    pub fn set_material_slot(&mut self, index: usize, preset: &Preset) {
        self.library.set_slot(index, preset);
    }

    /// Exchanges material slot `index` with `sampler` (real-time safe: no allocation; the previous
    /// sampler ends up in `sampler`, to be dropped off the audio thread). The current object is
    /// kept, even when `index` is the current material: drawing one is too costly for an audio
    /// block, so the caller installs the new material's object ([`Engine::install_object`],
    /// drawn elsewhere) or draws it ([`Engine::draw_object`]). Out-of-range: no-op.
    pub fn swap_material_slot(&mut self, index: usize, sampler: &mut ObjectSampler) {
        self.library.swap_slot(index, sampler);
    }

    /// Switches to material `index` (clamped) and draws an object with `seed`, if it differs from
    /// the current material. Real-time safe; ringing voices keep their modes.
    pub fn select_material(&mut self, index: usize, seed: u64) {
        if self.library.clamp(index) != self.library.material() {
            self.draw_object(index, seed);
        }
    }

    /// Index of the current material.
    pub fn material_index(&self) -> usize {
        self.library.material()
    }

    /// The current material preset.
    pub fn preset(&self) -> &Preset {
        self.library.preset()
    }

    /// The preset of material slot `index` (clamped), e.g. to bound the cost of drawing from it
    /// before [`Engine::draw_object`].
    pub fn preset_at(&self, index: usize) -> &Preset {
        self.library.preset_at(index)
    }

    /// Draws a new object with `seed` (no allocation, but up to
    /// [`object::MAX_REJECTION_TRIES`] Cholesky products: see [`ObjectSampler::sample`]; ringing
    /// voices keep their modes).
    pub fn new_object(&mut self, seed: u64) {
        self.draw_object(self.library.material(), seed);
    }

    /// Switches to material `index` (clamped) and draws its object with `seed`, whatever the
    /// current material and seed.
    pub fn draw_object(&mut self, index: usize, seed: u64) {
        self.library.draw(index, seed);
        self.object_installed(seed);
    }

    /// Makes `object`, drawn elsewhere from material `index` (clamped) with `seed`, the current
    /// object, exactly as [`Engine::draw_object`] would have drawn it; the previous object ends
    /// up in `object`. Real-time safe and cheap: buffers are exchanged, nothing is drawn,
    /// allocated or freed (both objects have [`SampledObject::with_capacity`] storage).
    pub fn install_object(&mut self, index: usize, seed: u64, object: &mut SampledObject) {
        self.library.install(index, seed, object);
        self.object_installed(seed);
    }

    /// What follows every new object besides the library's own bookkeeping: the hit RNG, the
    /// next hit is the object's first, and the bodies of the old object are gone (their hits
    /// fall back to the new object until its own are drawn).
    fn object_installed(&mut self, seed: u64) {
        self.hit_rng = EngineRng::seed_from_u64(seed ^ 0x5DEECE66D);
        self.struck = false;
        self.bodies.clear();
    }

    /// Makes room for `capacity` gesture bodies (allocates; not real-time safe). Without it
    /// [`Engine::draw_bodies`] draws none.
    pub fn reserve_bodies(&mut self, capacity: usize) {
        if self.bodies.capacity() < capacity {
            self.bodies = BodySet::with_capacity(capacity);
            self.bodies_generation = self.bodies_generation.wrapping_add(1);
        }
    }

    /// Draws the first `count` bodies of the current object ([`bodies::body_seed`]; at most the
    /// reserved number). No allocation, but `count` object draws: see [`Engine::draw_object`].
    pub fn draw_bodies(&mut self, count: usize) {
        let seed = self.library.seed();
        self.bodies.draw(self.library.sampler_mut(), seed, count);
        self.bodies_generation = self.bodies_generation.wrapping_add(1);
    }

    /// Makes `bodies`, drawn elsewhere for the current object exactly as
    /// [`Engine::draw_bodies`] would, the engine's; the previous set ends up in `bodies`
    /// (buffers exchanged, nothing allocated or freed).
    pub fn install_bodies(&mut self, bodies: &mut BodySet) {
        std::mem::swap(&mut self.bodies, bodies);
        self.bodies_generation = self.bodies_generation.wrapping_add(1);
    }

    /// Number of gesture bodies drawn for the current object.
    pub fn body_count(&self) -> usize {
        self.bodies.len()
    }

    /// Number of material slots.
    pub fn material_count(&self) -> usize {
        self.library.len()
    }

    /// The current object.
    pub fn object(&self) -> &SampledObject {
        self.library.object()
    }

    /// Seed of the current object.
    pub fn object_seed(&self) -> u64 {
        self.library.seed()
    }

    /// Sample rate in Hz.
    pub fn sample_rate(&self) -> f64 {
        self.sample_rate
    }

    /// The benchmark switches in force.
    pub fn options(&self) -> EngineOptions {
        self.options
    }

    /// Sets all benchmark switches at once (default: everything on). Real-time safe.
    pub fn set_options(&mut self, options: EngineOptions) {
        self.options = options;
    }

    /// Enables or disables the impact transient ([`EngineOptions::transient`]).
    pub fn set_transient_enabled(&mut self, enabled: bool) {
        self.options.transient = enabled;
    }

    /// Enables or disables mode culling ([`EngineOptions::culling`]): off, every mode below
    /// Nyquist runs until its voice sleeps.
    pub fn set_culling_enabled(&mut self, enabled: bool) {
        self.options.culling = enabled;
    }

    /// Enables or disables re-strike merging ([`EngineOptions::merging`]).
    ///
    /// On: an impact on the object a voice still rings from (same object, size, damping and key;
    /// that voice's contact over) adds its excitation to that voice's modes instead of starting
    /// a second voice with copies of the same modes. The bank is linear and the poles are
    /// identical, so the sum of the two copies' states *is* one mode's state: the output is the
    /// same up to f32 rounding, with one set of modes computed instead of one per hit. The old
    /// hit's noise transient, if still sounding, moves to a voice of its own. Off, every hit
    /// takes a voice (the benchmark's "nothing skipped" reference).
    pub fn set_merging_enabled(&mut self, enabled: bool) {
        self.options.merging = enabled;
    }

    /// The largest contact force in N (impacts, scraping, rolling; per-sample means) computed
    /// since the previous call, and resets it: the editor's contact-force meter. Never allocates.
    pub fn take_force_peak_n(&mut self) -> f32 {
        let f = std::mem::take(&mut self.force_peak_n);
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
        !self.voices.any() && !self.contacts.any_awake()
    }

    /// Number of voices currently sounding.
    pub fn active_voices(&self) -> usize {
        self.voices.count_active()
    }

    /// Whether the scraping / rolling force generators computed the last chunk.
    pub fn contacts_live(&self) -> (bool, bool) {
        self.contacts.live()
    }

    /// Whether the scraping / rolling banks are ringing (not asleep).
    pub fn contacts_awake(&self) -> (bool, bool) {
        self.contacts.awake()
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
        // Idle fast path: nothing sounding and nothing that could start (no events, no speed
        // buffers, constant speeds exactly 0; NaN speeds take the full path, which sanitises
        // them).
        if events.is_empty()
            && speed.scrape_m_per_s.is_none()
            && speed.roll_m_per_s.is_none()
            && settings.scrape.speed_m_per_s == 0.0
            && settings.roll.speed_m_per_s == 0.0
            && self.try_process_idle(settings.output.gain_db, left, right)
        {
            return;
        }
        self.process_full(settings, events, speed, left, right);
    }

    /// Whether the engine is idle at the block boundary: a block with no events and zero
    /// contact speeds then takes the idle fast path ([`Engine::try_process_idle`]).
    #[inline]
    pub fn takes_idle_path(&self) -> bool {
        self.idle
    }

    /// The idle fast path of a block with no events and zero contact speeds, for callers that
    /// know both without building [`Settings`] (the plugin's idle block): if the engine is idle
    /// ([`Engine::takes_idle_path`]), renders the block exactly as [`Engine::process_with_speed`]
    /// would (silence; the output gain ramps towards `gain_db`) and returns true; otherwise
    /// does nothing and returns false. Costs a few comparisons and clearing the outputs
    /// (`modal::clear_pair`).
    #[inline]
    pub fn try_process_idle(&mut self, gain_db: f64, left: &mut [f32], right: &mut [f32]) -> bool {
        if !self.idle {
            return false;
        }
        let len = left.len().min(right.len());
        modal::clear_pair(self.kernel, &mut left[..len], &mut right[..len]);
        self.stats.idle_blocks += 1;
        let gain_db = OutputSettings {
            gain_db,
            ..OutputSettings::default()
        }
        .sanitized()
        .gain_db;
        self.out_gain.set_target(gain_db);
        self.out_gain.apply(&mut left[..len], true);
        self.width.skip(len);
        self.time += len as u64;
        true
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
        // A sized preset (docs/measured.md, "Size") draws its object from the family of the
        // size class the size setting falls in; when the size crosses into another class, the
        // object is drawn again with its seed, as a new object of that size.
        if self.library.set_size(s.impact.size) {
            self.draw_object(self.library.material(), self.library.seed());
        }
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
            let (has_scrape, has_roll) = self.contacts.load_speeds(&speed, pos, end);
            self.render(
                &s,
                &mut left[pos..end],
                &mut right[pos..end],
                has_scrape,
                has_roll,
            );
            pos = end;
        }
        self.idle = self.is_idle();
    }

    fn apply_event(&mut self, s: &Settings, e: &Event) {
        match *e {
            Event::Impact {
                velocity_m_per_s,
                pitch_factor,
                key,
                ..
            } => self.start_impact(s, velocity_m_per_s, pitch_factor, [1.0, 1.0, 1.0, 0.0], 0, key),
            Event::BodyImpact {
                body,
                velocity_m_per_s,
                pitch_factor,
                mass_factor,
                gain,
                damping_factor,
                min_decay_db_per_s,
                key,
                ..
            } => self.start_impact(
                s,
                velocity_m_per_s,
                pitch_factor,
                [mass_factor, gain, damping_factor, min_decay_db_per_s],
                body as usize,
                key,
            ),
            Event::Fracture { key, .. } => self.voices.fracture(key, gesture::FRACTURE_DECAY_DB_PER_S),
            Event::Choke { key, .. } => self.voices.choke(key),
            Event::NewObject { seed, .. } => self.new_object(seed),
        }
    }

    /// Takes the hit's mode levels from the object (docs/model.md §3: the first hit of an object
    /// sounds its drawn levels, every later hit perturbs them), drops the modes the culling
    /// policy does not start, and hands the hit to the voices. Why not perturb the first hit
    /// too: the noise's SD is a fraction of the *mean* mode power, so on a first hit it lifts
    /// modes 20 dB under the mean by several dB and a new object no longer sounds like the
    /// preset it was drawn from (measured on fitted steel-drum components: decay-vs-frequency
    /// slope −1.1…−0.3 unperturbed, −0.2…+0.7 perturbed; docs/presets.md).
    ///
    /// `body`: 0 the current object, `k ≥ 1` gesture body `k` (the object when not drawn);
    /// `factors`: on the contact mass, on the level per unit impulse and on the decay, and the
    /// least decay in dB/s (see [`Event::BodyImpact`]).
    fn start_impact(
        &mut self,
        s: &Settings,
        velocity: f64,
        pitch_factor: f64,
        factors: [f64; 4],
        body: usize,
        key: i32,
    ) {
        let velocity = clamp_finite(velocity, 0.0, 100.0, 0.0);
        if velocity <= 0.0 {
            return;
        }
        let pitch = clamp_finite(pitch_factor, 1e-3, 1e3, 1.0);
        let mass_factor = clamp_finite(factors[0], 1e-6, 1.0, 1.0);
        let gain = clamp_finite(factors[1], 0.0, 1e4, 1.0);
        let damping = s.impact.damping * clamp_finite(factors[2], 1e-3, 1e3, 1.0);
        let min_decay = clamp_finite(factors[3], 0.0, 1e5, 0.0);
        let preset = self.library.preset();
        let (stiffness, hc_exponent) = (
            preset.contact_stiffness_n_per_m * s.impact.hardness,
            preset.contact_exponent,
        );
        let (object, seed, struck, generation) = match self.bodies.body_mut(body) {
            Some((object, seed, struck)) => (
                object,
                seed,
                struck,
                // Bodies' voices never merge with the object's or another set's.
                self.library.generation() ^ self.bodies_generation.rotate_left(32) ^ ((body as u64) << 52),
            ),
            None => (
                self.library.object(),
                self.library.seed(),
                &mut self.struck,
                self.library.generation(),
            ),
        };
        let n = object.modes.len();
        if *struck {
            perturb_levels(
                &object.modes,
                s.impact.variation,
                &mut self.hit_rng,
                &mut self.levels_db[..n],
            );
        } else {
            for (l, m) in self.levels_db[..n].iter_mut().zip(&object.modes) {
                *l = m.level_db;
            }
            *struck = true;
        }
        let freq_scale = pitch * object.reference_size / s.impact.size;
        let strongest = self.levels_db[..n]
            .iter()
            .cloned()
            .fold(f64::NEG_INFINITY, f64::max);
        self.modes.clear();
        self.pans.clear();
        for (i, (m, &level)) in object.modes.iter().zip(&self.levels_db[..n]).enumerate() {
            if self.options.culling && culling::cut_at_hit(level, strongest, s.output.quality_db) {
                continue;
            }
            // A mode that builds up or rings is two resonators (docs/model.md "Build-up",
            // "Ring"), started or culled together from the one perturbed level. Its τ is the
            // object's, unscaled by size and damping: the fit measured it in seconds and has no
            // law for how it moves. A ring's decay follows the mode's (a ratio of it).
            let mode = ModeParams {
                freq_hz: m.freq_hz * freq_scale,
                decay_db_per_s: (m.decay_db_per_s * damping).max(min_decay),
                gain: if m.inverted { -1.0 } else { 1.0 } * gain * 10f64.powf(level / 20.0),
            };
            let (main, partner) = match m.rise_s > 0.0 {
                true => build_up_pair(mode, m.rise_s),
                false => ring_pair(mode, m.ring),
            };
            // At most MAX_MODES resonators (the banks' and this list's capacity): validation
            // keeps a preset's modes plus build-ups within it, so this only guards objects built
            // by hand; a mode whose pair does not fit is left out whole, never split.
            if self.modes.len() + 1 + partner.is_some() as usize > MAX_MODES {
                continue;
            }
            // Both resonators of a build-up share the mode's pan, so each channel hears the
            // pair's sum (its build-up) scaled by one gain.
            let pan = pan_group(seed, i);
            self.modes.push(main);
            self.pans.push(pan);
            if let Some(p) = partner {
                self.modes.push(p);
                self.pans.push(pan);
            }
        }
        let hit = Strike {
            modes: &self.modes,
            pans: &self.pans,
            key,
            object: body == 0,
            tuning: [
                generation,
                freq_scale.to_bits(),
                damping.to_bits(),
                min_decay.to_bits(),
            ],
            force: ImpactParams {
                hc_exponent,
                ..ImpactParams::new(
                    s.impact.mass_kg * mass_factor,
                    velocity,
                    stiffness,
                    s.impact.contact_model,
                )
            },
            bands: self.options.transient.then_some(&object.bands[..]),
            freq_scale,
            damping,
            gain,
            seed: self.hit_rng.next_u32_compat(),
        };
        self.voices.start(&hit, self.options.merging);
    }

    /// Retires decayed and culled modes and puts silent voices to sleep. Runs only at multiples of
    /// [`HOUSEKEEPING_INTERVAL`] samples of engine time, so its decisions do not depend on the
    /// host's block size (renders stay block-size independent).
    fn housekeeping(&mut self, s: &Settings) {
        self.contacts.housekeeping(&self.library.object_ref());
        self.culling.housekeeping(
            &mut self.voices,
            s.output.quality_db,
            self.options.culling,
            self.time,
        );
        self.voices.sleep_silent();
    }

    /// Renders one chunk (≤ `max_block`, not crossing the housekeeping grid) into `out` (left)
    /// and `right` (equal lengths). At width 0 (and no ramp running) the sources render mono
    /// into `out`, copied to `right`: the mono engine's render, bit for bit. Otherwise they add
    /// their mid to `out` and side to `right`, mixed to left/right by [`WidthRamp::mix`].
    fn render(&mut self, s: &Settings, out: &mut [f32], right: &mut [f32], has_scrape: bool, has_roll: bool) {
        let len = out.len();
        let right = &mut right[..len];
        self.width.set_target(s.output.width);
        let stereo = self.width.is_stereo();
        out.iter_mut().for_each(|v| *v = 0.0);
        if stereo {
            right.iter_mut().for_each(|v| *v = 0.0);
        }
        // Whether anything can write to `out` this chunk; an idle engine skips the output guard.
        let mut wrote = has_scrape || has_roll || self.contacts.any_awake();
        // Idle: no voice sounding, no contact ringing and nothing that could start one (no speed
        // buffer, zero constant speeds). Only the clock advances; the contact banks re-tune
        // (`update_modes`) when they next run, and housekeeping has nothing to retire.
        if !wrote
            && !(s.scrape.speed_m_per_s != 0.0)
            && !(s.roll.speed_m_per_s != 0.0)
            && !self.voices.any_sounding()
        {
            self.out_gain.set_target(s.output.gain_db);
            self.out_gain.apply(out, true);
            self.width.skip(len);
            right.copy_from_slice(out);
            self.time += len as u64;
            return;
        }
        self.contacts.render(
            s,
            &self.library.object_ref(),
            out,
            stereo.then_some(&mut *right),
            has_scrape,
            has_roll,
            &mut self.stats,
            &mut self.force_peak_n,
        );
        wrote |= self.contacts.any_awake();
        wrote |= self.voices.render(
            out,
            stereo.then_some(&mut *right),
            &mut self.stats,
            &mut self.force_peak_n,
        );
        self.time += len as u64;
        if self.time.is_multiple_of(HOUSEKEEPING_INTERVAL) {
            self.housekeeping(s);
        }
        self.out_gain.set_target(s.output.gain_db);
        if stereo {
            self.width.mix(out, right);
            // The same ramp on both channels: one gain state, applied twice.
            let mut gain_right = self.out_gain;
            gain_right.apply(right, !wrote);
        } else {
            self.width.skip(len);
        }
        self.out_gain.apply(out, !wrote);
        if wrote {
            // Output is always finite and never subnormal: decaying f64 tails pass through f32's
            // subnormal range when converted (hosts and clap-validator's fuzzer flag those).
            for o in out.iter_mut() {
                if !o.is_finite() || o.abs() < f32::MIN_POSITIVE {
                    *o = 0.0;
                }
            }
            if stereo {
                for o in right.iter_mut() {
                    if !o.is_finite() || o.abs() < f32::MIN_POSITIVE {
                        *o = 0.0;
                    }
                }
            }
        }
        if !stereo {
            right.copy_from_slice(out);
        }
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
