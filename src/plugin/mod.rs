//! The Tactus plugin (CLAP + VST3 via nice-plug): a thin layer that turns parameters and MIDI
//! into engine [`Settings`] and [`Event`]s. All allocation happens in `Default` and `activate`.

pub mod editor;
pub mod fit_job;
pub mod gestures;
pub mod objects;
pub mod params;
pub mod strike_pad;
pub mod stub_host;
pub mod user_preset;

use crate::engine::gesture::{
    BounceParams, BreakParams, GestureKind, RattleParams, G_M_PER_S2, MAX_RATTLE_OBJECTS,
};
use crate::engine::limiter::Limiter;
use crate::engine::object::ObjectSampler;
use crate::engine::Lifecycle;
use crate::engine::{
    materials, Ablation, Engine, Event, ImpactSettings, OutputSettings, RollParams, ScrapeParams, Settings,
    SpeedInput, DEFAULT_MAX_VOICES,
};
use editor::feed::EditorFeed;
use gestures::{merge_events, GesturePlayer};
use nice_plug::midi::Key;
use nice_plug::plugin::ParamValue;
use nice_plug::prelude::*;
use objects::{BodiesKey, ObjectKey, ObjectWorker, MAX_GESTURE_BODIES};
use params::{GestureChoice, NoteMode, TactusParams, STATE_VERSION};
use std::num::NonZeroU32;
use std::sync::atomic::Ordering;
use std::sync::{Arc, OnceLock};
use strike_pad::PadQueue;

/// Most events handled per block; more are dropped (never allocated for).
pub const MAX_EVENTS_PER_BLOCK: usize = 4096;

/// Seed of the first object when a plugin instance is created.
pub const DEFAULT_SEED: u64 = 1;

/// A gesture's hits have no fixed end: a rattle note shakes until its note-off, up to this long
/// (s).
pub const RATTLE_MAX_S: f64 = 3600.0;

/// Maps a MIDI velocity in 0..1 to a fraction of the `velocity` parameter: quadratic, so the
/// impact speed (and with it the level, which is proportional to the impulse 2·m·v) spans
/// 24 dB between velocities 30 and 120.
pub fn velocity_curve(midi_velocity: f32) -> f64 {
    let v = midi_velocity.clamp(0.0, 1.0) as f64;
    v * v
}

/// MIDI key → frequency factor relative to middle C (60): equal-tempered.
pub fn key_to_pitch(key: u8) -> f64 {
    ((key as f64 - 60.0) / 12.0).exp2()
}

/// MIDI CC number that scales the scrape speed (mod wheel).
pub const CC_SCRAPE_SPEED: u8 = 1;

/// What one incoming note event does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MidiAction {
    /// An engine event (impact, choke).
    Engine(Event),
    /// New value of [`Tactus::midi_scrape_speed`] (0..1).
    ScrapeSpeed(f32),
    /// New value of [`Tactus::midi_scrape_pressure`] (0..1).
    ScrapePressure(f32),
    /// Nothing (note-off, other CCs, …).
    Ignore,
}

fn unit(x: f32) -> f32 {
    if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Maps a note event of a block of `block_len` samples to an action. Pure, allocation-free and
/// total: timings past the block end land on its last sample, non-finite values become 0,
/// wildcard keys play middle C (note-on) or address every voice (choke), note-offs are ignored
/// (impacts ring out; choke stops them).
pub fn map_note_event<S>(ev: &NoteEvent<S>, block_len: u32, full_speed: f64, mode: NoteMode) -> MidiAction {
    let last = block_len.saturating_sub(1);
    match *ev {
        NoteEvent::NoteOn {
            timing,
            key,
            velocity,
            ..
        } => {
            let k = match key {
                Key::Number(k) => k.min(127),
                Key::Wildcard => 60,
            };
            let pitch_factor = match mode {
                NoteMode::Pitch => key_to_pitch(k),
                NoteMode::Fixed => 1.0,
            };
            let speed = if full_speed.is_finite() {
                full_speed.max(0.0)
            } else {
                0.0
            };
            MidiAction::Engine(Event::Impact {
                offset: timing.min(last),
                velocity_m_per_s: speed * velocity_curve(unit(velocity)),
                pitch_factor,
                key: k as i32,
            })
        }
        NoteEvent::Choke { timing, key, .. } => MidiAction::Engine(Event::Choke {
            offset: timing.min(last),
            key: match key {
                Key::Number(k) => k as i32,
                Key::Wildcard => -1,
            },
        }),
        NoteEvent::MidiCC { cc, value, .. } if cc == CC_SCRAPE_SPEED => MidiAction::ScrapeSpeed(unit(value)),
        NoteEvent::MidiChannelPressure { pressure, .. } | NoteEvent::PolyPressure { pressure, .. } => {
            MidiAction::ScrapePressure(unit(pressure))
        }
        _ => MidiAction::Ignore,
    }
}

/// Migrates a saved state to [`STATE_VERSION`] (see `docs/plugin.md`). States without a
/// `state_version` field are version 0 (before seeds and the user preset were saved): they get
/// the seed every instance used then ([`DEFAULT_SEED`]), an empty user preset and
/// `note_mode = Pitch`, so old projects sound as they did. A state without the `width`
/// parameter was saved when the plugin was mono: it loads at width 0 (not the new instance's
/// default), so it keeps its sound. Likewise a state without the `limiter` parameter was saved
/// when the output was unlimited: it loads with the limiter off, so every sample it rendered
/// renders unchanged (a new instance starts with it on).
pub fn migrate_state(state: &mut PluginState) {
    let version = state
        .fields
        .get("state_version")
        .and_then(|v| v.trim().parse::<u32>().ok())
        .unwrap_or(0);
    if version < 1 {
        let seed = DEFAULT_SEED.to_string();
        state.fields.insert("object_seed".into(), seed.clone());
        state.fields.insert("seed_base".into(), seed);
        state.fields.insert("new_object_latch".into(), "false".into());
        state
            .fields
            .entry("user_preset".into())
            .or_insert_with(|| "\"\"".into());
        state
            .params
            .insert("seed".into(), ParamValue::I32(DEFAULT_SEED as i32));
        state.params.insert("new_object".into(), ParamValue::Bool(false));
        state
            .params
            .insert("note_mode".into(), ParamValue::String("pitch".into()));
    }
    // Any version: the parameter is missing exactly when the state predates it.
    state.params.entry("width".into()).or_insert(ParamValue::F32(0.0));
    state
        .params
        .entry("limiter".into())
        .or_insert(ParamValue::Bool(false));
    // Future versions: `if version < 2 { … }` here.
    state
        .fields
        .insert("state_version".into(), STATE_VERSION.to_string());
}

/// The plugin.
pub struct Tactus {
    params: Arc<TactusParams>,
    engine: Engine,
    /// The block's MIDI events.
    events: Vec<Event>,
    /// The block's MIDI events and gesture hits, merged in time order: what the engine plays.
    merged: Vec<Event>,
    /// The gestures of notes played while `gesture` is not Strike.
    gestures: GesturePlayer,
    /// The gesture bodies the engine holds (none until a Break or Rattle asks for them).
    bodies: Option<BodiesKey>,
    /// Mod wheel (CC 1) in 0..1, the factor on the scrape speed (applied in one place,
    /// [`Tactus::scrape_speed`]). 1 until the first CC 1 arrives, so hosts without a mod wheel
    /// scrape at the parameter's speed. Updated once per block (last value in the block wins).
    pub midi_scrape_speed: f32,
    /// Channel aftertouch / polyphonic key pressure in 0..1 (last received, any key), for the
    /// scrape pressure; 1 until the first pressure message arrives.
    pub midi_scrape_pressure: f32,
    /// Per-sample smoothed scrape speed of the block (m/s), sized in `activate`.
    scrape_speed: Vec<f32>,
    /// The output limiter, applied after the engine while the `limiter` parameter is on.
    limiter: Limiter,
    /// Lock-free data for the editor (modes of the current object, meters).
    feed: Arc<EditorFeed>,
    /// The editor's strike pad presses and releases, played as notes of [`strike_pad::PAD_KEY`].
    pad: Arc<PadQueue>,
    /// Draws objects off the audio thread (see [`objects`]).
    objects: ObjectWorker,
    /// The object the engine holds now.
    current: ObjectKey,
    /// Whether the host renders offline ([`ProcessMode::Offline`]): every object is then drawn in
    /// `process` itself, so an offline render never depends on the worker's timing.
    offline: bool,
    /// Whether the editor's force meter has been told the engine runs (the idle block skips
    /// publishing a zero force once it has: a zero cannot raise the meter's peak).
    force_meter_live: bool,
    /// Editor window size, kept across open/close cycles.
    #[cfg(feature = "editor")]
    editor_state: Arc<nice_plug_egui::EguiEditorState>,
}

/// The samplers of the `material` parameter's slots as shipped: the built-ins, the user slot's
/// fallback material, the fitted families, the measured materials. Built once per process and cloned by every instance
/// and its worker: building them (Cholesky factors and a median over 255 draws per family) is
/// most of creating an instance, and JUCE hosts create several per load (docs/plugin.md, "MIDI",
/// load time).
fn shipped_samplers() -> &'static [ObjectSampler] {
    static SAMPLERS: OnceLock<Vec<ObjectSampler>> = OnceLock::new();
    SAMPLERS.get_or_init(|| {
        let mut presets = materials::builtin_presets();
        // The user slot starts as the fallback material until a preset is loaded.
        presets.push(user_preset::fallback_preset());
        // The fitted family presets follow the user slot in the `material` parameter, the
        // measured materials follow them.
        presets.extend(materials::family_presets());
        presets.extend(materials::measured_presets());
        presets.iter().map(ObjectSampler::new).collect()
    })
}

impl Default for Tactus {
    fn default() -> Self {
        let params = Arc::new(TactusParams::default());
        if let Ok(path) = std::env::var(user_preset::ENV_USER_PRESET) {
            if !path.trim().is_empty() {
                if let Err(e) = params.user_preset.load_file(&path) {
                    nice_log!("{e}");
                }
            }
        }
        let samplers = shipped_samplers();
        let mut engine = Engine::with_samplers(samplers.to_vec(), 1, DEFAULT_MAX_VOICES, DEFAULT_SEED);
        engine.reserve_bodies(MAX_GESTURE_BODIES);
        params.user_preset.apply_pending(&mut engine);
        let current = ObjectKey {
            material: engine.material_index(),
            seed: engine.object_seed(),
            library: 0,
        };
        let user = params.clone();
        let objects = ObjectWorker::spawn(samplers.to_vec(), move || user.user_preset.latest_sampler());
        Self {
            params,
            engine,
            events: Vec::with_capacity(MAX_EVENTS_PER_BLOCK),
            merged: Vec::with_capacity(MAX_EVENTS_PER_BLOCK),
            gestures: GesturePlayer::new(MAX_EVENTS_PER_BLOCK),
            bodies: None,
            midi_scrape_speed: 1.0,
            midi_scrape_pressure: 1.0,
            scrape_speed: Vec::new(),
            limiter: Limiter::new(48_000.0),
            feed: Arc::new(EditorFeed::default()),
            pad: Arc::new(PadQueue::default()),
            objects,
            current,
            offline: false,
            force_meter_live: false,
            #[cfg(feature = "editor")]
            editor_state: editor::default_state(),
        }
    }
}

impl Tactus {
    /// Engine settings for a block of `block_len` samples; `scrape_peak_m_per_s` is the block's
    /// scrape speed with the mod wheel applied ([`Tactus::scrape_speed`]), the one place the
    /// wheel enters. Smoothed parameters advance by the whole block (calling `next()` once per
    /// block would stretch a 20 ms ramp by the block size).
    fn settings(&self, block_len: u32, scrape_peak_m_per_s: f64) -> Settings {
        let p = &self.params;
        let steps = block_len.max(1);
        // One roughness parameter for both contacts: the plugin plays one surface.
        let roughness = p.roughness.smoothed.next_step(steps) as f64;
        let surface = p.surface.value().into();
        Settings {
            impact: ImpactSettings {
                size: p.size.value() as f64,
                damping: p.damping.value() as f64,
                mass_kg: p.mass.value() as f64,
                hardness: p.hardness.value() as f64,
                contact_model: p.contact_model.value().into(),
                variation: p.variation.value() as f64,
            },
            scrape: ScrapeParams {
                speed_m_per_s: scrape_peak_m_per_s,
                motion: p.scrape_motion.value().into(),
                pressure_n: (p.scrape_pressure.smoothed.next_step(steps) * self.midi_scrape_pressure) as f64,
                roughness,
                surface,
            },
            roll: RollParams {
                speed_m_per_s: p.roll_speed.smoothed.next_step(steps) as f64,
                radius_m: p.roll_radius.value() as f64,
                eccentricity: p.roll_eccentricity.value() as f64,
                pressure_n: p.roll_pressure.smoothed.next_step(steps) as f64,
                roughness,
                surface,
            },
            output: OutputSettings {
                quality_db: p.quality.value() as f64,
                gain_db: p.gain.smoothed.next_step(steps) as f64,
                width: p.width.value() as f64,
            },
            ablation: Ablation::default(),
        }
    }
}

impl Tactus {
    /// Applies the `seed` parameter and the `new_object` trigger to the persisted object seed and
    /// returns the seed the current object must have. Real-time safe (atomics only).
    fn update_object_seed(&mut self) -> u64 {
        let p = &self.params;
        let seed_param = p.seed.value().clamp(0, params::MAX_SEED) as u64;
        if seed_param != p.seed_base.load(Ordering::Acquire) {
            p.seed_base.store(seed_param, Ordering::Release);
            p.object_seed.store(seed_param, Ordering::Release);
        }
        let trigger = p.new_object.value();
        // A plain load first: the read-modify-write is only needed when the trigger moved, and
        // this runs every block.
        if trigger != p.new_object_latch.load(Ordering::Acquire)
            && trigger != p.new_object_latch.swap(trigger, Ordering::AcqRel)
            && trigger
        {
            let next = params::next_seed(p.object_seed.load(Ordering::Acquire));
            p.object_seed.store(next, Ordering::Release);
        }
        p.object_seed.load(Ordering::Acquire)
    }

    /// The scrape speed of a block of `n` samples, mod wheel applied: fills the per-sample buffer
    /// (smoothed parameter × wheel) that manual scraping reads and returns the constant peak
    /// speed the preset motions read (parameter × wheel), and whether the buffer is needed.
    /// An all-zero buffer is not passed on, so a plugin that does not scrape leaves the engine
    /// free to take its idle fast path. Real-time safe.
    fn scrape_speed(&mut self, n: usize) -> (f64, bool) {
        let wheel = self.midi_scrape_speed;
        let buf = &mut self.scrape_speed[..n];
        self.params.scrape_speed.smoothed.next_block(buf, n);
        buf.iter_mut().for_each(|v| *v *= wheel);
        let moving = buf.iter().any(|&v| v != 0.0);
        ((self.params.scrape_speed.value() * wheel) as f64, moving)
    }

    /// Renders a block with no events through the engine's idle fast path when that is exactly
    /// what the full path would do, and returns true; otherwise changes nothing and returns
    /// false. The full path's per-block work (a per-sample scrape-speed buffer, [`Settings`]
    /// from every parameter, the output peak scan) is skipped because, for an idle engine, its
    /// only effects are the output gain and whether a contact starts: a smoother that is not
    /// smoothing returns its target and changes no state, a zero scrape and roll speed start
    /// nothing, and the idle path's output is silence (peak 0, force 0). A parameter changed
    /// while idle is read by the next full block, the one that plays the next hit.
    #[inline]
    fn idle_block(&mut self, buffer: &mut Buffer) -> bool {
        let p = &self.params;
        if !self.engine.takes_idle_path()
            || p.scrape_speed.smoothed.is_smoothing()
            || p.roll_speed.smoothed.is_smoothing()
            || p.scrape_pressure.smoothed.is_smoothing()
            || p.roughness.smoothed.is_smoothing()
            || p.roll_pressure.smoothed.is_smoothing()
            // Not `!= 0.0`: NaN takes the full path, as in the engine.
            || !(p.scrape_speed.value() * self.midi_scrape_speed == 0.0)
            || !(p.roll_speed.value() == 0.0)
        {
            return false;
        }
        let len = buffer.samples() as u32;
        let out = buffer.as_slice();
        if out.len() < 2 {
            return false;
        }
        let gain_db = p.gain.smoothed.next_step(len.max(1)) as f64;
        let (l, r) = out.split_at_mut(1);
        // True: `takes_idle_path` was checked above and nothing ran on the engine since.
        if !self.engine.try_process_idle(gain_db, l[0], r[0]) {
            return false;
        }
        if !self.force_meter_live {
            self.feed.publish_force_peak(self.engine.take_force_peak_n());
            self.force_meter_live = true;
        }
        true
    }

    /// The strike pad's queue, as the editor holds it: what is pushed here plays at the start
    /// of the next block as a note of [`strike_pad::PAD_KEY`] (tests drive the pad through it).
    pub fn strike_pad(&self) -> Arc<PadQueue> {
        self.pad.clone()
    }

    /// The plugin's parameters and persisted fields, as the editor holds them (tests drive the
    /// editor's fit path, [`fit_job::FitJob`], with it).
    pub fn tactus_params(&self) -> Arc<TactusParams> {
        self.params.clone()
    }

    /// The object the engine holds now (it lags the parameters while the worker draws).
    pub fn object_key(&self) -> ObjectKey {
        self.current
    }

    /// The smallest gain the output limiter applied since the previous call (1 = it did
    /// nothing; tests, measurements).
    pub fn take_limiter_min_gain(&mut self) -> f32 {
        self.limiter.take_min_gain()
    }

    /// Number of gesture bodies the engine holds for its object (tests).
    pub fn body_count(&self) -> usize {
        self.engine.body_count()
    }

    /// The engine's work counters since the previous call (tests, measurements).
    pub fn take_engine_stats(&mut self) -> crate::engine::Stats {
        self.engine.take_stats()
    }

    /// The object the parameters ask for now (applies the seed parameter and the `new_object`
    /// trigger, see [`Tactus::update_object_seed`]). Real-time safe.
    fn wanted_object(&mut self) -> ObjectKey {
        let seed = self.update_object_seed();
        let last = self.engine.material_count() - 1;
        let material = (self.params.material.value().max(0) as usize).min(last);
        let library = if material == user_preset::USER_SLOT {
            self.params.user_preset.applied_generation()
        } else {
            0
        };
        ObjectKey {
            material,
            seed,
            library,
        }
    }

    /// Brings the engine's object up to date before a block of `block_len` samples. A missing
    /// object is drawn here when `draw` (activation, offline rendering) or when its draw fits the
    /// block's budget ([`objects::cheap_enough`]): the change then takes effect at this block
    /// whatever the host's speed. Otherwise it is taken from the worker when ready, and the
    /// previous object keeps sounding until then (never waits; ringing voices keep their modes
    /// either way). Never allocates.
    fn update_object(&mut self, block_len: usize, draw: bool) {
        self.params.user_preset.apply_pending(&mut self.engine);
        let want = self.wanted_object();
        if want != self.current {
            if draw || objects::cheap_enough(self.engine.preset_at(want.material), block_len) {
                self.engine.draw_object(want.material, want.seed);
                self.current = want;
            } else if self.objects.try_install(want, &mut self.engine) {
                self.current = want;
            }
        }
        self.update_bodies(block_len, draw);
    }

    /// Number of gesture bodies the `gesture` parameter's notes strike besides the object: a
    /// break's dust and fragments, a rattle's objects ([`crate::engine::bodies`]).
    fn bodies_needed(&self) -> usize {
        let p = &self.params;
        let n = p.fragments.value().max(1) as usize;
        match p.gesture.value() {
            GestureChoice::Strike | GestureChoice::Bounce => 0,
            GestureChoice::Break => 1 + n.min(MAX_GESTURE_BODIES - 1),
            GestureChoice::Rattle => n.min(MAX_RATTLE_OBJECTS as usize),
        }
    }

    /// Brings the engine's gesture bodies up to the current object and the `gesture` parameter,
    /// by the rule objects follow ([`Tactus::update_object`]): drawn here when `draw` or cheap
    /// enough for the block, else by the worker. Until they are there, their hits sound the
    /// object itself at their sizes (docs/plugin.md, "Gestures"). Never allocates.
    fn update_bodies(&mut self, block_len: usize, draw: bool) {
        let count = self.bodies_needed();
        if count == 0
            || self
                .bodies
                .is_some_and(|b| b.object == self.current && b.count >= count)
        {
            return;
        }
        let want = BodiesKey {
            object: self.current,
            count,
        };
        if draw || objects::draws_cheap_enough(self.engine.preset_at(want.object.material), count, block_len)
        {
            self.engine.draw_bodies(count);
            self.bodies = Some(want);
        } else if self.objects.try_install_bodies(want, &mut self.engine) {
            self.bodies = Some(want);
        }
    }

    /// The gesture a note plays under the `gesture` parameter, `None` for a plain strike.
    /// `strength` is the note velocity's share of full speed ([`velocity_curve`]), `strike` the
    /// note's strike speed (m/s).
    fn note_gesture(&self, strength: f64, strike: f64) -> Option<GestureKind> {
        let p = &self.params;
        let restitution = p.restitution.value() as f64;
        match p.gesture.value() {
            GestureChoice::Strike => None,
            GestureChoice::Bounce => Some(GestureKind::Bounce(BounceParams {
                velocity_m_per_s: (2.0 * G_M_PER_S2 * p.height.value() as f64).sqrt() * strength,
                restitution,
                ..Default::default()
            })),
            GestureChoice::Break => Some(GestureKind::Break(BreakParams {
                velocity_m_per_s: strike,
                fragments: p.fragments.value().max(1) as u32,
                restitution,
                spread_s: p.spread.value() as f64,
            })),
            GestureChoice::Rattle => Some(GestureKind::Rattle(RattleParams {
                duration_s: RATTLE_MAX_S,
                objects: (p.fragments.value().max(1) as u32).min(MAX_RATTLE_OBJECTS),
                rate_hz: p.rattle_rate.value() as f64,
                intensity: strength,
            })),
        }
    }
}

impl Tactus {
    /// One note event of a block of `len` samples, from the host or the strike pad: a note-on
    /// starts an impact or the `gesture` parameter's gesture, a note-off releases a rattle, a
    /// choke stops its key, controllers set the scrape. Never allocates.
    fn note_event(&mut self, ev: NoteEvent<()>, len: u32) {
        let full_speed = self.params.velocity.value() as f64;
        let mode = self.params.note_mode.value();
        if let NoteEvent::NoteOff { timing, key, .. } = ev {
            let key = match key {
                Key::Number(k) => k.min(127) as i32,
                Key::Wildcard => -1,
            };
            self.gestures.release(key, timing.min(len.saturating_sub(1)));
        }
        match map_note_event(&ev, len, full_speed, mode) {
            MidiAction::Engine(Event::Impact {
                offset,
                velocity_m_per_s,
                pitch_factor,
                key,
            }) if self.params.gesture.value() != GestureChoice::Strike => {
                let strength = match ev {
                    NoteEvent::NoteOn { velocity, .. } => velocity_curve(unit(velocity)),
                    _ => 0.0,
                };
                if let Some(kind) = self.note_gesture(strength, velocity_m_per_s) {
                    if strength > 0.0 {
                        self.gestures
                            .start(kind, offset, key, pitch_factor, self.current.seed);
                    }
                }
            }
            MidiAction::Engine(e) => {
                if let Event::Choke { offset, key } = e {
                    self.gestures.choke(key, offset);
                }
                if self.events.len() < self.events.capacity() {
                    self.events.push(e);
                }
            }
            MidiAction::ScrapeSpeed(v) => self.midi_scrape_speed = v,
            MidiAction::ScrapePressure(v) => self.midi_scrape_pressure = v,
            MidiAction::Ignore => {}
        }
    }
}

impl Plugin for Tactus {
    const NAME: &'static str = "Tactus";
    const VENDOR: &'static str = "Tactus";
    const URL: &'static str = "https://example.invalid/tactus";
    const EMAIL: &'static str = "tactus@example.invalid";
    const VERSION: &'static str = env!("CARGO_PKG_VERSION");

    const AUDIO_IO_LAYOUTS: &'static [AudioIOLayout] = &[AudioIOLayout {
        main_input_channels: None,
        main_output_channels: NonZeroU32::new(2),
        ..AudioIOLayout::const_default()
    }];

    const MIDI_INPUT: MidiConfig = MidiConfig::MidiCCs;
    const SAMPLE_ACCURATE_AUTOMATION: bool = false;

    type SysExMessage = ();
    type BackgroundTask = ();
    #[cfg(feature = "editor")]
    type Editor = nice_plug_egui::EguiEditor<editor::TactusEditor>;
    #[cfg(not(feature = "editor"))]
    type Editor = ();

    fn filter_state(state: &mut PluginState) {
        migrate_state(state);
    }

    fn params(&self) -> Arc<dyn Params> {
        self.params.clone()
    }

    #[cfg(feature = "editor")]
    fn editor(&mut self, _async_executor: AsyncExecutor<Self>) -> Option<Self::Editor> {
        editor::create_editor(
            self.params.clone(),
            self.feed.clone(),
            self.pad.clone(),
            self.editor_state.clone(),
        )
    }

    fn activate(
        &mut self,
        _layout: &AudioIOLayout,
        config: &BufferConfig,
        _context: &mut impl ActivateContext<Self>,
    ) -> bool {
        let max_block = (config.max_buffer_size as usize).clamp(1, 1 << 16);
        self.engine.prepare(config.sample_rate as f64, max_block);
        self.scrape_speed = vec![0.0; max_block];
        self.limiter = Limiter::new(config.sample_rate as f64);
        self.offline = config.process_mode == ProcessMode::Offline;
        self.gestures.reset(self.engine.sample_rate());
        // Off the audio thread: the object a restored state or changed parameters ask for is
        // drawn now, so the first block after activation plays it.
        self.update_object(max_block, true);
        true
    }

    fn reset(&mut self) {
        self.engine.reset();
        self.limiter.reset();
        self.gestures.reset(self.engine.sample_rate());
    }

    fn process(
        &mut self,
        buffer: &mut Buffer,
        _aux: &mut AuxiliaryBuffers,
        context: &mut impl ProcessContext<Self>,
    ) -> ProcessStatus {
        self.update_object(buffer.samples(), self.offline);
        self.feed
            .publish_object_if_changed(self.current.material, self.current.seed, self.engine.object());
        let first = context.next_event();
        let len = buffer.samples() as u32;
        if first.is_none() && self.pad.is_empty() && !self.gestures.any_active() && self.idle_block(buffer) {
            self.gestures.skip(len);
            // The idle block is silence: the limiter's gain releases over it as over zeros.
            self.limiter.skip(len as usize);
            return ProcessStatus::Normal;
        }
        self.events.clear();
        // The pad's presses first, at the block's first sample: they were made before the
        // block, and the host's events are sorted from there.
        while let Some(pad) = self.pad.pop() {
            self.note_event(strike_pad::note(pad), len);
        }
        let mut next = first;
        while let Some(ev) = next {
            next = context.next_event();
            self.note_event(ev, len);
        }
        let out = buffer.as_slice();
        if out.len() >= 2 {
            let (l, r) = out.split_at_mut(1);
            let n = (len as usize).min(self.scrape_speed.len());
            // After the block's MIDI: the wheel read here is the one the whole block uses.
            let (peak_speed, moving) = self.scrape_speed(n);
            let settings = self.settings(len, peak_speed);
            let speed = SpeedInput {
                scrape_m_per_s: moving.then_some(&self.scrape_speed[..n]),
                roll_m_per_s: None,
            };
            let hits = self.gestures.block(len);
            let events = if hits.is_empty() {
                &self.events
            } else {
                merge_events(&self.events, hits, &mut self.merged);
                &self.merged
            };
            self.engine
                .process_with_speed(&settings, events, speed, l[0], r[0]);
            if self.params.limiter.value() {
                self.limiter.process_stereo(l[0], r[0]);
            } else {
                // Switched back on, it starts at unity gain, not at a gain from before.
                self.limiter.reset();
            }
            let peak = out
                .iter()
                .flat_map(|ch| ch.iter())
                .fold(0.0f32, |m, x| m.max(x.abs()));
            self.feed.publish_output_peak(peak);
            // The largest force the engine computed in this block (impacts, scrape, roll).
            self.feed.publish_force_peak(self.engine.take_force_peak_n());
            self.force_meter_live = true;
        } else {
            // Only a stereo layout is offered; anything else gets silence rather than a crash.
            out.iter_mut().for_each(|ch| ch.fill(0.0));
            self.gestures.skip(len);
        }
        ProcessStatus::Normal
    }
}

impl ClapPlugin for Tactus {
    const CLAP_ID: &'static str = "org.tactus.tactus";
    const CLAP_DESCRIPTION: Option<&'static str> =
        Some("Physically based impact, scraping and rolling sounds from a modal resonator bank");
    const CLAP_MANUAL_URL: Option<&'static str> = None;
    const CLAP_SUPPORT_URL: Option<&'static str> = None;
    const CLAP_FEATURES: &'static [ClapFeature] = &[
        ClapFeature::Instrument,
        ClapFeature::Synthesizer,
        ClapFeature::Stereo,
    ];
}

impl Vst3Plugin for Tactus {
    const VST3_CLASS_ID: [u8; 16] = *b"TactusContactSyn";
    const VST3_SUBCATEGORIES: &'static [Vst3SubCategory] = &[
        Vst3SubCategory::Instrument,
        Vst3SubCategory::Synth,
        Vst3SubCategory::Stereo,
    ];
    /// The mod wheel and channel pressure only (docs/plugin.md, "MIDI"): VST3 delivers MIDI
    /// controllers as parameter changes, and nice-plug would otherwise expose all 130
    /// controllers of all 16 channels as 2080 hidden parameters, which JUCE hosts enumerate on
    /// every load and state restore. Poly pressure arrives as a VST3 event, not a proxy.
    const VST3_MIDI_CONTROLLERS: Option<&'static [u8]> = Some(&[CC_SCRAPE_SPEED, VST3_CHANNEL_PRESSURE]);
}

/// nice-plug's controller number for channel pressure in [`Vst3Plugin::VST3_MIDI_CONTROLLERS`]
/// (VST3's `kAfterTouch`).
const VST3_CHANNEL_PRESSURE: u8 = 128;

nice_export_clap!(Tactus);
nice_export_vst3!(Tactus);
