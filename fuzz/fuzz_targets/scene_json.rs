//! Any bytes as a scene file: `Scene::parse` must return a scene or an error, never panic; a
//! scene it accepts must render finite audio (renders are cut to 0.25 s to keep runs fast).
#![no_main]

use libfuzzer_sys::fuzz_target;
use tactus::scene::{self, Scene};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(mut loaded) = Scene::parse(&text, None) else {
        return;
    };
    loaded.scene.duration_s = loaded.scene.duration_s.min(0.25);
    let (l, r) = scene::render(&loaded, 512, |_| {});
    assert!(l.iter().chain(&r).all(|v| v.is_finite()), "non-finite output");
});
