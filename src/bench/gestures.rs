//! Gesture rows: the example scenes of each gesture (`scenes/*.json`) and a 64-fragment break,
//! rendered by the scene renderer as `tactus render` does (object draws of the fragments and
//! rattling objects included), timed as CPU time per second of audio.

use super::*;
use crate::scene::{render, Scene};

/// The example scene of each gesture and a break into the most fragments.
const SCENES: [(&str, &str); 4] = [
    (
        "bounce (scenes/bounce.json)",
        include_str!("../../scenes/bounce.json"),
    ),
    (
        "break, 8 fragments (scenes/break.json)",
        include_str!("../../scenes/break.json"),
    ),
    (
        "rattle, 5 objects (scenes/rattle.json)",
        include_str!("../../scenes/rattle.json"),
    ),
    (
        "break, 64 fragments",
        r#"{"duration_s": 3.0, "seed": 2, "material": "glass", "settings": {"gain_db": -12},
            "events": [{"type": "break", "time_s": 0.1, "velocity_m_per_s": 4.0, "fragments": 64,
                        "restitution": 0.4, "spread_s": 0.5}]}"#,
    ),
];

/// One row per gesture scene: the whole render's CPU time (min of `reps`), block 256.
pub(super) fn gesture_rows(reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    let mut rows = Vec::new();
    for (name, json) in SCENES {
        let scene = Scene::parse(json, None).expect("the bench's gesture scenes are valid");
        let len = (scene.scene.duration_s * FS) as usize;
        let mut best = f64::INFINITY;
        for _ in 0..reps.max(1) {
            let t0 = CpuClock::now();
            let out = render(&scene, 256);
            best = best.min(t0.elapsed_secs());
            std::hint::black_box(out);
        }
        let r = row(
            name,
            "scene render, block 256".into(),
            len,
            best,
            0,
            f64::NAN,
            f64::NAN,
        );
        log(&r);
        rows.push(r);
    }
    rows
}
