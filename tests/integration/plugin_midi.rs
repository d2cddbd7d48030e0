//! Plugin logic without a host: MIDI mapping (bad input, floods) with an allocation counter,
//! the user preset slot, seeds and state migration.

use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::plugin::{ParamValue, PluginState};
use nice_plug::prelude::NoteEvent;
use std::collections::BTreeMap;
use tactus::engine::{materials, Engine, Event, Settings, DEFAULT_MAX_VOICES};
use tactus::plugin::params::{next_seed, NoteMode, MAX_SEED, STATE_VERSION};
use tactus::plugin::user_preset::{UserPresetSlot, USER_SLOT};
use tactus::plugin::{map_note_event, migrate_state, MidiAction, DEFAULT_SEED, MAX_EVENTS_PER_BLOCK};

use crate::counting_alloc::allocs;

fn on(timing: u32, key: Key, velocity: f32) -> NoteEvent<()> {
    NoteEvent::NoteOn {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key,
        velocity,
    }
}

fn engine() -> Engine {
    let mut presets = materials::builtin_presets();
    presets.push(tactus::plugin::user_preset::fallback_preset());
    let mut e = Engine::with_library(&presets, 1, DEFAULT_MAX_VOICES, DEFAULT_SEED);
    e.prepare(48_000.0, 512);
    e
}

#[test]
fn bad_midi_maps_safely() {
    let len = 512;
    // Wildcard key → middle C, timing past the block → last sample, NaN velocity → silent hit.
    match map_note_event(&on(10_000, Key::Wildcard, f32::NAN), len, 1.0, NoteMode::Pitch) {
        MidiAction::Engine(Event::Impact {
            offset,
            velocity_m_per_s,
            pitch_factor,
            key,
        }) => {
            assert_eq!(offset, 511);
            assert_eq!(velocity_m_per_s, 0.0);
            assert_eq!(pitch_factor, 1.0);
            assert_eq!(key, 60);
        }
        other => panic!("{other:?}"),
    }
    // Key 200 is clamped; negative/huge velocities are clamped; a zero-length block is fine.
    assert!(matches!(
        map_note_event(&on(0, Key::Number(200), 7.0), 0, f64::INFINITY, NoteMode::Pitch),
        MidiAction::Engine(Event::Impact { offset: 0, key: 127, velocity_m_per_s, .. }) if velocity_m_per_s == 0.0
    ));
    // Note-off without note-on: ignored.
    let off = NoteEvent::<()>::NoteOff {
        timing: 3,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Number(61),
        velocity: 0.0,
    };
    assert_eq!(
        map_note_event(&off, len, 1.0, NoteMode::Pitch),
        MidiAction::Ignore
    );
    // Wildcard choke addresses every voice.
    let choke = NoteEvent::<()>::Choke {
        timing: 1,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Wildcard,
    };
    assert_eq!(
        map_note_event(&choke, len, 1.0, NoteMode::Pitch),
        MidiAction::Engine(Event::Choke { offset: 1, key: -1 })
    );
}

#[test]
fn note_modes_and_controllers() {
    let pitch = |mode| match map_note_event(&on(0, Key::Number(72), 1.0), 64, 2.0, mode) {
        MidiAction::Engine(Event::Impact { pitch_factor, .. }) => pitch_factor,
        other => panic!("{other:?}"),
    };
    assert!((pitch(NoteMode::Pitch) - 2.0).abs() < 1e-12);
    assert_eq!(pitch(NoteMode::Fixed), 1.0);
    let cc = |cc, value| NoteEvent::<()>::MidiCC {
        timing: 0,
        channel: 0,
        cc,
        value,
    };
    assert_eq!(
        map_note_event(&cc(1, 0.25), 64, 1.0, NoteMode::Pitch),
        MidiAction::ScrapeSpeed(0.25)
    );
    assert_eq!(
        map_note_event(&cc(1, f32::NAN), 64, 1.0, NoteMode::Pitch),
        MidiAction::ScrapeSpeed(0.0)
    );
    assert_eq!(
        map_note_event(&cc(7, 0.5), 64, 1.0, NoteMode::Pitch),
        MidiAction::Ignore
    );
    let at = NoteEvent::<()>::MidiChannelPressure {
        timing: 0,
        channel: 0,
        pressure: 3.0,
    };
    assert_eq!(
        map_note_event(&at, 64, 1.0, NoteMode::Pitch),
        MidiAction::ScrapePressure(1.0)
    );
    let poly = NoteEvent::<()>::PolyPressure {
        timing: 0,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Wildcard,
        pressure: 0.5,
    };
    assert_eq!(
        map_note_event(&poly, 64, 1.0, NoteMode::Pitch),
        MidiAction::ScrapePressure(0.5)
    );
}

#[test]
fn flood_of_notes_neither_panics_nor_allocates() {
    let mut e = engine();
    let mut events: Vec<Event> = Vec::with_capacity(MAX_EVENTS_PER_BLOCK);
    let (mut l, mut r) = (vec![0.0f32; 512], vec![0.0f32; 512]);
    let settings = Settings::default();
    for block in 0..4u32 {
        let before = allocs();
        events.clear();
        for i in 0..1000u32 {
            let key = if i % 7 == 0 {
                Key::Wildcard
            } else {
                Key::Number((i % 128) as u8)
            };
            let ev = if i % 5 == 0 {
                NoteEvent::NoteOff {
                    timing: i,
                    voice_id: VoiceID::Wildcard,
                    channel: Channel::Wildcard,
                    key,
                    velocity: 0.0,
                }
            } else {
                on((i * 7 + block) % 600, key, (i % 128) as f32 / 127.0)
            };
            if let MidiAction::Engine(ev) = map_note_event(&ev, 512, 1.0, NoteMode::Pitch) {
                if events.len() < events.capacity() {
                    events.push(ev);
                }
            }
        }
        events.sort_unstable_by_key(|e| e.offset()); // in place, no buffer (hosts deliver events sorted)
        e.process(&settings, &events, &mut l, &mut r);
        assert_eq!(allocs(), before, "allocation in block {block}");
        assert!(l.iter().chain(r.iter()).all(|x| x.is_finite()));
    }
}

#[test]
fn user_preset_slot_hands_over_and_falls_back() {
    let slot = UserPresetSlot::default();
    let mut e = engine();
    e.select_material(USER_SLOT, 5);
    let fallback_first = e.object().modes.first().map(|m| m.freq_hz);

    let glass = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/presets/glass.json")).unwrap();
    slot.set_json(glass.clone()).unwrap();
    assert!(slot.status().is_empty());
    let before = allocs();
    assert!(slot.apply_pending(&mut e), "fresh preset is swapped in");
    assert!(!slot.apply_pending(&mut e), "only once");
    assert_eq!(allocs(), before, "the audio-thread hand-over allocated");
    assert_eq!(
        e.preset().name,
        tactus::preset::Preset::from_json(&glass, None).unwrap().name
    );
    // The swap keeps the current object (drawing is the object worker's job); a draw from the
    // slot now gives a glass object.
    assert_eq!(e.object().modes.first().map(|m| m.freq_hz), fallback_first);
    assert_eq!(slot.applied_generation(), slot.generation());
    e.draw_object(USER_SLOT, 5);
    assert_ne!(e.object().modes.first().map(|m| m.freq_hz), fallback_first);

    // Unreadable saved preset: fallback material, error text, JSON kept for re-saving.
    let err = slot.set_json("{ not json".into()).unwrap_err();
    assert!(!err.is_empty());
    assert_eq!(slot.status(), err);
    assert_eq!(slot.json(), "{ not json");
    assert!(slot.apply_pending(&mut e));
    assert_eq!(
        e.preset().name,
        tactus::plugin::user_preset::fallback_preset().name
    );

    // A bad file from the editor changes nothing but the status.
    let g = slot.generation();
    assert!(slot.load_file("/nonexistent/preset.json").is_err());
    assert_eq!(slot.generation(), g);
    assert!(slot.status().contains("cannot read"));
}

#[test]
fn next_seed_is_deterministic_and_in_range() {
    let mut s = DEFAULT_SEED;
    let mut seen = std::collections::HashSet::new();
    for _ in 0..1000 {
        let n = next_seed(s);
        assert_eq!(n, next_seed(s));
        assert!(n <= MAX_SEED as u64 && n != s);
        seen.insert(n);
        s = n;
    }
    assert!(seen.len() > 990);
}

#[test]
fn old_states_migrate_to_the_current_version() {
    let mut state = PluginState {
        version: "0.1.0".into(),
        params: BTreeMap::from([("material".to_string(), ParamValue::I32(3))]),
        fields: BTreeMap::new(),
    };
    migrate_state(&mut state);
    assert_eq!(state.fields["state_version"], STATE_VERSION.to_string());
    assert_eq!(state.fields["object_seed"], DEFAULT_SEED.to_string());
    assert_eq!(state.fields["user_preset"], "\"\"");
    assert!(matches!(state.params["seed"], ParamValue::I32(1)));
    assert!(matches!(state.params["material"], ParamValue::I32(3)));
    // Saved when the plugin was mono: it stays mono (not the new instance's default width).
    assert!(matches!(state.params["width"], ParamValue::F32(w) if w == 0.0));
    // Saved when the output was unlimited: it stays unlimited, so it renders as it did.
    assert!(matches!(state.params["limiter"], ParamValue::Bool(false)));
    // A current state is left alone.
    let mut cur = state.clone();
    cur.fields.insert("object_seed".into(), "42".into());
    cur.params.insert("width".into(), ParamValue::F32(0.7));
    cur.params.insert("limiter".into(), ParamValue::Bool(true));
    migrate_state(&mut cur);
    assert_eq!(cur.fields["object_seed"], "42");
    assert!(matches!(cur.params["width"], ParamValue::F32(w) if w == 0.7));
    assert!(matches!(cur.params["limiter"], ParamValue::Bool(true)));
}
