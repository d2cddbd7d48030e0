//! The Tactus plugin (CLAP + VST3 via nice-plug): a thin layer that turns parameters and MIDI
//! into engine [`Settings`] and [`Event`]s. All allocation happens in `Default` and `activate`.

pub mod params;

use crate::editor::feed::EditorFeed;
use crate::engine::sustained::MotionKind;
use crate::engine::{materials, Engine, Event, Settings, SpeedInput, DEFAULT_MAX_VOICES};
use nice_plug::midi::Key;
use nice_plug::prelude::*;
use params::{ScrapeMotionChoice, TactusParams};
use std::num::NonZeroU32;
use std::sync::Arc;

/// Most events handled per block; more are dropped (never allocated for).
pub const MAX_EVENTS_PER_BLOCK: usize = 4096;

/// Seed of the first object when a plugin instance is created.
pub const DEFAULT_SEED: u64 = 1;

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

/// The plugin.
pub struct Tactus {
    params: Arc<TactusParams>,
    engine: Engine,
    events: Vec<Event>,
    /// Per-sample smoothed scrape speed of the block (m/s), sized in `activate`.
    scrape_speed: Vec<f32>,
    /// Lock-free data for the editor (modes of the current object, meters).
    feed: Arc<EditorFeed>,
    /// Editor window size, kept across open/close cycles.
    #[cfg(feature = "editor")]
    editor_state: Arc<nice_plug_egui::EguiEditorState>,
}

impl Default for Tactus {
    fn default() -> Self {
        let presets = materials::builtin_presets();
        Self {
            params: Arc::new(TactusParams::default()),
            engine: Engine::with_library(&presets, 1, DEFAULT_MAX_VOICES, DEFAULT_SEED),
            events: Vec::with_capacity(MAX_EVENTS_PER_BLOCK),
            scrape_speed: Vec::new(),
            feed: Arc::new(EditorFeed::default()),
            #[cfg(feature = "editor")]
            editor_state: crate::editor::default_state(),
        }
    }
}

impl Tactus {
    /// Engine settings for a block of `block_len` samples. Smoothed parameters advance by the
    /// whole block (calling `next()` once per block would stretch a 20 ms ramp by the block size).
    fn settings(&self, block_len: u32) -> Settings {
        let p = &self.params;
        let steps = block_len.max(1);
        Settings {
            size: p.size.value() as f64,
            damping: p.damping.value() as f64,
            mass_kg: p.mass.value() as f64,
            hardness: p.hardness.value() as f64,
            contact_model: p.contact_model.value().into(),
            variation: p.variation.value() as f64,
            quality_db: p.quality.value() as f64,
            gain_db: p.gain.smoothed.next_step(steps) as f64,
            // Manual scraping reads the per-sample `scrape_speed` buffer; this target is the peak
            // speed of the preset motions.
            scrape_speed_m_per_s: p.scrape_speed.value() as f64,
            scrape_motion: match p.scrape_motion.value() {
                ScrapeMotionChoice::Manual => MotionKind::Manual,
                ScrapeMotionChoice::BackAndForth => MotionKind::BackAndForth,
                ScrapeMotionChoice::Circular => MotionKind::Circular,
                ScrapeMotionChoice::Strokes => MotionKind::Strokes,
                ScrapeMotionChoice::Scribble => MotionKind::Scribble,
                ScrapeMotionChoice::LongStroke => MotionKind::LongStroke,
            },
            scrape_pressure_n: p.scrape_pressure.smoothed.next_step(steps) as f64,
            roughness: p.roughness.smoothed.next_step(steps) as f64,
            roll_speed_m_per_s: p.roll_speed.smoothed.next_step(steps) as f64,
            roll_radius_m: p.roll_radius.value() as f64,
            roll_eccentricity: p.roll_eccentricity.value() as f64,
            ..Settings::default()
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

    const MIDI_INPUT: MidiConfig = MidiConfig::Basic;
    const SAMPLE_ACCURATE_AUTOMATION: bool = false;

    type SysExMessage = ();
    type BackgroundTask = ();
    #[cfg(feature = "editor")]
    type Editor = nice_plug_egui::EguiEditor<crate::editor::TactusEditor>;
    #[cfg(not(feature = "editor"))]
    type Editor = ();

    fn params(&self) -> Arc<dyn Params> {
        self.params.clone()
    }

    #[cfg(feature = "editor")]
    fn editor(&mut self, _async_executor: AsyncExecutor<Self>) -> Option<Self::Editor> {
        crate::editor::create_editor(self.params.clone(), self.feed.clone(), self.editor_state.clone())
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
        true
    }

    fn reset(&mut self) {
        self.engine.reset();
    }

    fn process(
        &mut self,
        buffer: &mut Buffer,
        _aux: &mut AuxiliaryBuffers,
        context: &mut impl ProcessContext<Self>,
    ) -> ProcessStatus {
        let material = self.params.material.value().max(0) as usize;
        let seed = self.engine.object_seed();
        self.engine.select_material(material, seed);
        self.feed
            .publish_object_if_changed(material, seed, self.engine.object());
        let len = buffer.samples() as u32;
        let settings = self.settings(len);
        let full_speed = self.params.velocity.value() as f64;
        self.events.clear();
        while let Some(ev) = context.next_event() {
            if self.events.len() == self.events.capacity() {
                continue;
            }
            match ev {
                NoteEvent::NoteOn {
                    timing,
                    key,
                    velocity,
                    ..
                } => {
                    let k = match key {
                        Key::Number(k) => k,
                        Key::Wildcard => 60,
                    };
                    self.events.push(Event::Impact {
                        offset: timing.min(len.saturating_sub(1)),
                        velocity_m_per_s: full_speed * velocity_curve(velocity),
                        pitch_factor: key_to_pitch(k),
                        key: k as i32,
                    });
                }
                NoteEvent::Choke { timing, key, .. } => {
                    let k = match key {
                        Key::Number(k) => k as i32,
                        Key::Wildcard => -1,
                    };
                    self.events.push(Event::Choke {
                        offset: timing.min(len.saturating_sub(1)),
                        key: k,
                    });
                }
                _ => {}
            }
        }
        let out = buffer.as_slice();
        if out.len() >= 2 {
            let (l, r) = out.split_at_mut(1);
            let n = (len as usize).min(self.scrape_speed.len());
            self.params
                .scrape_speed
                .smoothed
                .next_block(&mut self.scrape_speed[..n], n);
            let speed = SpeedInput {
                scrape_m_per_s: Some(&self.scrape_speed[..n]),
                roll_m_per_s: None,
            };
            self.engine
                .process_with_speed(&settings, &self.events, speed, l[0], r[0]);
            let peak = out
                .iter()
                .flat_map(|ch| ch.iter())
                .fold(0.0f32, |m, x| m.max(x.abs()));
            self.feed.publish_output_peak(peak);
        } else {
            // Only a stereo layout is offered; anything else gets silence rather than a crash.
            out.iter_mut().for_each(|ch| ch.fill(0.0));
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
}

nice_export_clap!(Tactus);
nice_export_vst3!(Tactus);
