//! Scraping and rolling inside the engine (src/engine/mod.rs + src/engine/sustained/channel.rs)
//! and in scenes: properties that can fail.

use tactus::engine::materials::builtin_presets;
use tactus::engine::sustained::{MotionKind, SurfaceKind};
use tactus::engine::{Ablation, Engine, Settings, SpeedInput};
use tactus::scene::{render, Scene, DEMO_SCENE};

pub(crate) const FS: f64 = 48_000.0;

fn engine() -> Engine {
    let mut e = Engine::new(&builtin_presets()[1], 8, 3);
    e.prepare(FS, 512);
    e
}

/// Renders `n` samples with `settings`, the scrape speed buffer taken from `speed` (if any).
fn run(e: &mut Engine, s: &Settings, speed: Option<&[f32]>, n: usize, block: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; n];
    let mut r = vec![0.0f32; block];
    let mut pos = 0;
    while pos < n {
        let end = (pos + block).min(n);
        let sp = SpeedInput {
            scrape_m_per_s: speed.map(|b| &b[pos..end]),
            roll_m_per_s: None,
        };
        e.process_with_speed(s, &[], sp, &mut out[pos..end], &mut r[..end - pos]);
        pos = end;
    }
    out
}

pub(crate) fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|&v| (v as f64) * (v as f64)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

fn scrape_settings(speed: f64, pressure: f64) -> Settings {
    Settings {
        scrape: tactus::engine::ScrapeParams {
            speed_m_per_s: speed,
            pressure_n: pressure,
            roughness: 0.8,
            ..Default::default()
        },
        roll: tactus::engine::RollParams {
            roughness: 0.8,
            ..Default::default()
        },
        ..Settings::default()
    }
}

#[test]
fn zero_speed_or_pressure_is_silent_and_computes_no_force() {
    let cases = [
        scrape_settings(0.0, 5.0),
        scrape_settings(1.0, 0.0),
        Settings {
            roll: tactus::engine::RollParams {
                speed_m_per_s: 0.0,
                pressure_n: 2.0,
                ..Default::default()
            },
            ..Settings::default()
        },
        Settings {
            roll: tactus::engine::RollParams {
                speed_m_per_s: 1.0,
                pressure_n: 0.0,
                ..Default::default()
            },
            ..Settings::default()
        },
    ];
    for (i, s) in cases.iter().enumerate() {
        let mut e = engine();
        let out = run(&mut e, s, None, 24_000, 480);
        assert!(out.iter().all(|&v| v == 0.0), "case {i}: not silent");
        let st = e.take_stats();
        assert_eq!(st.force_samples, 0, "case {i}");
        assert_eq!(st.mode_samples, 0, "case {i}");
    }
    // Zero speed *buffer* in manual mode: also nothing computed.
    let mut e = engine();
    let zeros = vec![0.0f32; 24_000];
    let out = run(&mut e, &scrape_settings(1.0, 5.0), Some(&zeros), 24_000, 480);
    assert!(out.iter().all(|&v| v == 0.0));
    assert_eq!(e.take_stats().force_samples, 0);
}

#[test]
fn scrape_then_stop_rings_out_to_exact_silence_and_sleeps() {
    let mut e = engine();
    let loud = run(&mut e, &scrape_settings(0.5, 5.0), None, 24_000, 512);
    assert!(rms(&loud) > 1e-6, "scrape is silent: {}", rms(&loud));
    let st = e.take_stats();
    assert_eq!(st.force_samples, 24_000);
    assert!(st.mode_samples > 0);
    // Stop: the bank free-rings (no force), then sleeps; output becomes exactly 0.
    let s0 = scrape_settings(0.0, 5.0);
    let tail = run(&mut e, &s0, None, 48_000 * 20, 512);
    assert_eq!(e.take_stats().force_samples, 0);
    assert!(!e.contacts_awake().0, "scrape bank never slept");
    let last = &tail[tail.len() - 48_000..];
    assert!(
        last.iter().all(|&v| v == 0.0),
        "not exactly silent after ring-out"
    );
    let _ = run(&mut e, &s0, None, 4_800, 512);
    assert_eq!(
        e.take_stats().mode_samples,
        0,
        "a sleeping bank still costs mode samples"
    );
}

#[test]
fn speed_ramp_automation_is_continuous_at_breakpoints() {
    let n = 48_000;
    // Breakpoints at 0.1 s, 0.4 s, 0.6 s: 0 → 0.8 m/s → hold → 0.2 m/s.
    let bps = [4_800usize, 19_200, 28_800];
    let speed: Vec<f32> = (0..n)
        .map(|i| {
            let v = if i < bps[0] {
                0.05
            } else if i < bps[1] {
                0.05 + 0.75 * (i - bps[0]) as f64 / (bps[1] - bps[0]) as f64
            } else if i < bps[2] {
                0.8
            } else {
                0.8 - 0.6 * ((i - bps[2]) as f64 / (n - bps[2]) as f64)
            };
            v as f32
        })
        .collect();
    let mut e = engine();
    let out = run(&mut e, &scrape_settings(0.0, 5.0), Some(&speed), n, 128);
    assert!(rms(&out) > 1e-6);
    for &b in &bps {
        let step = (b - 2..b + 3)
            .map(|i| (out[i] - out[i - 1]).abs())
            .fold(0.0f32, f32::max);
        let around = (b - 480..b + 480)
            .filter(|i| !(b - 2..b + 3).contains(i))
            .map(|i| (out[i] - out[i - 1]).abs())
            .fold(0.0f32, f32::max);
        assert!(around > 0.0);
        assert!(
            step <= around,
            "breakpoint {b}: step {step} > local variation {around}"
        );
    }
}

#[test]
fn loudness_rises_with_scrape_speed() {
    let mut last = 0.0;
    for v in [0.05, 0.2, 0.8] {
        let mut e = engine();
        let out = run(&mut e, &scrape_settings(v, 5.0), None, 48_000, 512);
        let r = rms(&out[12_000..]);
        assert!(r > last * 1.2, "speed {v}: rms {r} not above {last}");
        last = r;
    }
}

#[test]
fn loudness_rises_with_roll_speed() {
    let mut last = 0.0;
    for v in [0.1, 0.4, 1.6] {
        let mut e = engine();
        let s = Settings {
            roll: tactus::engine::RollParams {
                speed_m_per_s: v,
                pressure_n: 2.0,
                ..Default::default()
            },
            ..Settings::default()
        };
        let out = run(&mut e, &s, None, 48_000, 512);
        let r = rms(&out[12_000..]);
        assert!(r > last, "roll speed {v}: rms {r} not above {last}");
        last = r;
    }
}

#[test]
fn scene_with_scrape_and_roll_is_deterministic_across_block_sizes() {
    let mut s = Scene::parse(DEMO_SCENE, None).unwrap();
    s.scene
        .events
        .retain(|e| !matches!(e, tactus::scene::SceneEvent::Impact { .. }));
    let (a, _) = render(&s, 512);
    let (b, _) = render(&s, 512);
    assert_eq!(a, b);
    let peak = a.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    // Scrape 2.8–5.2 s and roll 5.4–7.6 s both sound.
    assert!(
        rms(&a[(3.2 * FS) as usize..(4.8 * FS) as usize]) > 1e-5,
        "scrape silent"
    );
    assert!(
        rms(&a[(5.8 * FS) as usize..(7.4 * FS) as usize]) > 1e-5,
        "roll silent"
    );
    for block in [37, 256, 1000] {
        let (c, _) = render(&s, block);
        let d = a.iter().zip(&c).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        // −90 dB of the peak: the f32 projection of the free-ringing path and the f64 excited
        // path meet at block edges, so a different split rounds differently (measured 1.05e-5
        // of the peak at block 37 after the speed-scaled smoothing made the scrape quieter).
        assert!(
            d <= 3e-5 * peak,
            "block {block} changed output by {d} (peak {peak})"
        );
    }
}

#[test]
fn ablation_switches_change_the_sound() {
    let base = scrape_settings(0.5, 5.0);
    let reference = run(&mut engine(), &base, None, 24_000, 512);
    for (name, ab) in [
        (
            "curvature_limit",
            Ablation {
                curvature_limit: false,
                ..Ablation::default()
            },
        ),
        (
            "surface_ir_only",
            Ablation {
                surface_ir_only: true,
                ..Ablation::default()
            },
        ),
        (
            "morphing",
            Ablation {
                morphing: false,
                ..Ablation::default()
            },
        ),
    ] {
        let s = Settings { ablation: ab, ..base };
        let out = run(&mut engine(), &s, None, 24_000, 512);
        let d = reference
            .iter()
            .zip(&out)
            .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(d > 1e-4 * rms(&reference) as f32, "{name} changed nothing");
    }
}

#[test]
fn abuse_grid_output_is_finite() {
    let bad = [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        -1e30,
        0.0,
        1e-30,
        1e30,
    ];
    let mut e = engine();
    let mut speed = vec![0.0f32; 512];
    for (i, &x) in bad.iter().enumerate() {
        for (j, &y) in bad.iter().enumerate() {
            let s = Settings {
                scrape: tactus::engine::ScrapeParams {
                    speed_m_per_s: x,
                    pressure_n: y,
                    roughness: x,
                    motion: [MotionKind::Manual, MotionKind::Circular, MotionKind::Scribble][(i + j) % 3],
                    surface: SurfaceKind::ALL[(i + 2 * j) % SurfaceKind::ALL.len()],
                },
                roll: tactus::engine::RollParams {
                    roughness: x,
                    speed_m_per_s: y,
                    radius_m: x,
                    eccentricity: y,
                    pressure_n: x,
                    surface: SurfaceKind::ALL[(2 * i + j) % SurfaceKind::ALL.len()],
                },
                ..Settings::default()
            };
            speed
                .iter_mut()
                .enumerate()
                .for_each(|(k, v)| *v = bad[(k + i) % bad.len()] as f32);
            let mut l = vec![0.0f32; 512];
            let mut r = vec![0.0f32; 512];
            let sp = SpeedInput {
                scrape_m_per_s: Some(&speed),
                roll_m_per_s: Some(&speed[..100]),
            };
            e.process_with_speed(&s, &[], sp, &mut l, &mut r);
            assert!(
                l.iter().chain(&r).all(|v| v.is_finite()),
                "non-finite at ({x}, {y})"
            );
        }
    }
}

#[test]
fn bad_contact_events_explain_themselves() {
    let wrap = |ev: &str| format!(r#"{{"duration_s": 2, "material": "wood", "events": [{ev}]}}"#);
    let cases = [
        (
            r#"{"type": "scrape", "time_s": 0, "duration_s": 1, "speed_m_per_s": 1, "bogus": 1}"#,
            "bogus",
        ),
        (
            r#"{"type": "scrape", "time_s": 0, "duration_s": 1}"#,
            "speed_m_per_s or speed_curve",
        ),
        (
            r#"{"type": "scrape", "time_s": 0, "duration_s": 1, "motion": "circular", "speed_curve": [[0, 1]]}"#,
            "manual",
        ),
        (
            r#"{"type": "roll", "time_s": 0, "duration_s": 1, "speed_m_per_s": 1, "radius_m": 5}"#,
            "radius_m",
        ),
        (
            r#"{"type": "roll", "time_s": 0, "duration_s": 1, "speed_curve": [[1, 0], [0.5, 1]]}"#,
            "non-decreasing",
        ),
        (
            r#"{"type": "scrape", "time_s": 0, "duration_s": 1, "speed_m_per_s": 1, "motion": "zigzag"}"#,
            "zigzag",
        ),
    ];
    for (ev, needle) in cases {
        let e = Scene::parse(&wrap(ev), None).unwrap_err().to_string();
        assert!(e.contains(needle), "{ev}: {e}");
    }
    let overlap = wrap(
        r#"{"type": "roll", "time_s": 0, "duration_s": 1, "speed_m_per_s": 1},
           {"type": "roll", "time_s": 0.5, "duration_s": 1, "speed_m_per_s": 1}"#,
    );
    assert!(Scene::parse(&overlap, None)
        .unwrap_err()
        .to_string()
        .contains("overlap"));
    let ab = r#"{"duration_s": 1, "material": "wood", "ablation": {"morphin": false}}"#;
    assert!(Scene::parse(ab, None)
        .unwrap_err()
        .to_string()
        .contains("morphin"));
}
