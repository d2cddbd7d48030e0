//! Helpers shared by the integration tests (recordings folder, one rendered hit). Each test
//! crate uses some of them, hence `allow(dead_code)`.
#![allow(dead_code)]

use std::path::PathBuf;
use tactus::engine::{Engine, Event, Settings};
use tactus::preset::Preset;

/// The recordings folder: `$TACTUS_RECORDINGS`, else `../shared/recordings` beside the checkout.
/// `None` (and a "SKIPPED" line on stderr) when it does not exist, so those tests skip.
pub fn recordings() -> Option<PathBuf> {
    let dir = std::env::var_os("TACTUS_RECORDINGS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/recordings"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIPPED: recordings folder {} not found (set TACTUS_RECORDINGS)",
            dir.display()
        );
        None
    }
}

/// One impact at t = 0 (1 m/s, pitch factor 1, no key) on the object `Engine::new(preset, 4,
/// seed)` draws, rendered with `settings` for `seconds` at `fs` in blocks of `block` samples.
/// Returns the engine (its object, for the drawn modes) and the left and right channels.
pub fn render_one_hit(
    preset: &Preset,
    seed: u64,
    settings: &Settings,
    fs: f64,
    seconds: f64,
    block: usize,
) -> (Engine, Vec<f32>, Vec<f32>) {
    let total = (seconds * fs) as usize;
    let mut e = Engine::new(preset, 4, seed);
    e.prepare(fs, block);
    let (mut l, mut r) = (vec![0f32; total], vec![0f32; total]);
    let mut pos = 0;
    while pos < total {
        let n = block.min(total - pos);
        let ev: &[Event] = if pos == 0 {
            &[Event::Impact {
                offset: 0,
                velocity_m_per_s: 1.0,
                pitch_factor: 1.0,
                key: -1,
            }]
        } else {
            &[]
        };
        e.process(settings, ev, &mut l[pos..pos + n], &mut r[pos..pos + n]);
        pos += n;
    }
    (e, l, r)
}
