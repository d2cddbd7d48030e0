//! Any bytes as a preset file: `Preset::from_json` must return a value or an error, never
//! panic; a preset it accepts must render finite audio.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tactus::engine::{Engine, Event, Settings};
use tactus::preset::Preset;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(preset) = Preset::from_json(&text, Some("fuzz")) else {
        return;
    };
    let mut engine = Engine::new(&preset, 4, 1);
    engine.prepare(48_000.0, 256);
    let (mut l, mut r) = (vec![0.0f32; 256], vec![0.0f32; 256]);
    let hit = [Event::Impact {
        offset: 0,
        velocity_m_per_s: 1.0,
        pitch_factor: 1.0,
        key: -1,
    }];
    for block in 0..8 {
        let events: &[Event] = if block == 0 { &hit } else { &[] };
        engine.process(&Settings::default(), events, &mut l, &mut r);
        assert!(l.iter().chain(&r).all(|v| v.is_finite()), "non-finite output");
    }
});
