//! Wood vs metal discrimination (issue #4): an impact rendered by the engine from the shipped
//! wood preset must be closer (mean normalised feature distance, `tactus::fit::features`) to the
//! wood DEV recordings than to the metal ones, and vice versa, for ≥ 95 of 100 seeded objects.
//!
//! Features per sound: log10 tan φ (decay rate vs frequency, α = π f tan φ, fitted over the
//! strongest modes by energy) and log2 spectral centroid (50 Hz…9 kHz) of the audio. For the
//! recordings tan φ comes from the modes `tactus fit` extracts from the audio (after merging
//! near-coincident copies); for the renders from the rendered object's own mode list (extracting
//! 200 renders would take ~8 min; the centroid is still measured on the rendered audio). Distance: Euclidean after dividing each feature by its
//! pooled within-material standard deviation over the recordings. See `src/fit/features.rs`.
//!
//! It also prints the metric's ceiling: each recording judged by the same rule against the
//! other recordings (leave one out); on the DEV set 14/14 wood and only 7/12 metal (docs/presets.md).
//!
//! Skips with a message when the recordings folder (`../shared/recordings` or
//! `$TACTUS_RECORDINGS`) is absent.
//! Run: `cargo test --test fit_discrimination -- --ignored --nocapture`.

use tactus::engine::materials::builtin_presets;
use tactus::engine::Settings;
use tactus::fit::audio::read_wav;
use tactus::fit::cli::expand_inputs;
use tactus::fit::extract::Mode;
use tactus::fit::features::{distance, features, features_with_modes, mean_distance, pooled_std};
use tactus::preset::Preset;

const DRAWS: u64 = 100;
const REQUIRED: usize = 95;
const FS: f64 = 44_100.0;
/// Render length, s (the recordings last 0.1…3.3 s; 1.5 s covers most of a metal decay).
const SECONDS: f64 = 1.5;

mod common;
use common::{recordings, render_one_hit};

/// One impact at t = 0 (default settings: 50 g striker at 1 m/s) on the object drawn with `seed`;
/// returns the left channel and the object's modes (as the engine plays them, size 1).
fn render(preset: &Preset, seed: u64) -> (Vec<f64>, Vec<Mode>) {
    let (e, l, _) = render_one_hit(preset, seed, &Settings::default(), FS, SECONDS, 512);
    let out = l.iter().map(|&v| f64::from(v)).collect();
    let modes = e
        .object()
        .modes
        .iter()
        .map(|m| Mode {
            freq_hz: m.freq_hz,
            level_db: m.level_db,
            decay_db_per_s: m.decay_db_per_s,
            phase: 0.0,
            attack_s: 0.0,
        })
        .collect();
    (out, modes)
}

#[test]
#[ignore = "fails: Metal 88/100 (Wood 100/100); the metal recordings themselves score 7/12 by this rule (leave one out), see docs/presets.md; run with --ignored"]
fn fitted_wood_and_metal_presets_are_discriminated() {
    let Some(dir) = recordings() else { return };
    let files = expand_inputs(&[dir]).expect("list recordings");
    let (mut wood, mut metal) = (Vec::new(), Vec::new());
    for f in &files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        let rec = read_wav(f).unwrap_or_else(|e| panic!("{e:#}"));
        let ft = features(&rec.samples, rec.sample_rate).unwrap_or_else(|| panic!("{name}: no features"));
        println!(
            "{name:<64} tan phi {:.2e} centroid {:7.0} Hz ({} modes)",
            ft.tan_phi, ft.centroid_hz, ft.modes_used
        );
        if name.starts_with("wood") {
            wood.push(ft.vector());
        } else if name.starts_with("metal") {
            metal.push(ft.vector());
        }
    }
    assert!(
        wood.len() >= 2 && metal.len() >= 2,
        "need wood and metal recordings"
    );
    let scale = pooled_std(&[&wood, &metal]);
    println!(
        "pooled std: log10 tan phi {:.3}, log2 centroid {:.3}",
        scale[0], scale[1]
    );
    // The metric's own ceiling: each recording against the *other* recordings (leave one
    // out), by the same rule the draws are judged by. A preset that reproduced its recordings
    // faithfully would score about this share, so it says what the 95 % target can ask of it.
    for (own, other, label) in [(&wood, &metal, "wood"), (&metal, &wood, "metal")] {
        // `nn` and `cm`, for information only: the same with the nearest recording, and with the
        // distance to the material's mean feature vector, instead of the mean distance.
        let (mut ok, mut nn, mut cm) = (0, 0, 0);
        for (i, v) in own.iter().enumerate() {
            let rest: Vec<[f64; 2]> = own
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, w)| *w)
                .collect();
            if mean_distance(v, &rest, &scale) < mean_distance(v, other, &scale) {
                ok += 1;
            }
            if nearest(v, &rest, &scale) < nearest(v, other, &scale) {
                nn += 1;
            }
            if distance(v, &centre(&rest), &scale) < distance(v, &centre(other), &scale) {
                cm += 1;
            }
        }
        println!(
            "leave-one-out: {ok}/{} {label} recordings closer to the other {label} recordings \
             (not asserted: nearest recording {nn}/{}, material mean {cm}/{})",
            own.len(),
            own.len(),
            own.len()
        );
    }
    let presets = builtin_presets();
    let mut counts = Vec::new();
    for (preset, is_wood) in [(&presets[0], true), (&presets[1], false)] {
        assert_eq!(preset.material_class, if is_wood { "wood" } else { "metal" });
        let mut correct = 0;
        let mut correct_nn = 0;
        let mut correct_cm = 0;
        let (wood_centre, metal_centre) = (centre(&wood), centre(&metal));
        let mut failed = 0;
        for seed in 0..DRAWS {
            let (x, modes) = render(preset, seed);
            let Some(ft) = features_with_modes(&x, FS, &modes) else {
                let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                eprintln!(
                    "{} seed {seed}: no features ({} modes, tan φ {:?}, peak {peak:.2e})",
                    preset.name,
                    modes.len(),
                    tactus::fit::features::tan_phi(&modes)
                );
                failed += 1;
                continue;
            };
            let v = ft.vector();
            let (dw, dm) = (
                mean_distance(&v, &wood, &scale),
                mean_distance(&v, &metal, &scale),
            );
            if (nearest(&v, &wood, &scale) < nearest(&v, &metal, &scale)) == is_wood {
                correct_nn += 1;
            }
            if (distance(&v, &wood_centre, &scale) < distance(&v, &metal_centre, &scale)) == is_wood {
                correct_cm += 1;
            }
            if (dw < dm) == is_wood {
                correct += 1;
            } else {
                println!(
                    "{} seed {seed}: tan phi {:.2e} centroid {:.0} Hz, d(wood) {dw:.2} d(metal) {dm:.2}",
                    preset.name, ft.tan_phi, ft.centroid_hz
                );
            }
        }
        println!(
            "{}: {correct}/{DRAWS} draws closer to the {} recordings ({failed} without features; \
             not asserted: by the nearest recording {correct_nn}/{DRAWS}, by the material mean \
             {correct_cm}/{DRAWS})",
            preset.name, preset.material_class
        );
        counts.push((preset.name.clone(), correct));
    }
    for (name, c) in counts {
        assert!(
            c >= REQUIRED,
            "{name}: only {c}/{DRAWS} draws discriminated (need {REQUIRED})"
        );
    }
}

/// Normalised distance to the nearest member of `group` (reported beside the asserted mean
/// distance, to show how much the verdict depends on the rule).
fn nearest(a: &[f64; 2], group: &[[f64; 2]], scale: &[f64; 2]) -> f64 {
    group
        .iter()
        .map(|b| distance(a, b, scale))
        .fold(f64::INFINITY, f64::min)
}

/// Mean feature vector of `group` (the "material mean" reported beside the asserted rule).
fn centre(group: &[[f64; 2]]) -> [f64; 2] {
    let n = group.len().max(1) as f64;
    [
        group.iter().map(|v| v[0]).sum::<f64>() / n,
        group.iter().map(|v| v[1]).sum::<f64>() / n,
    ]
}
