//! The plugin under nice-plug's own real-time check (`assert_process_allocs`, feature
//! `rt-checks`), every `process` call inside nice-plug's `assert_no_alloc` as its VST3 and CLAP
//! wrappers run it: fitting ten recordings (the editor's fit path, [`FitJob`], on its worker),
//! and offline rendering that draws objects of the worst-case preset in `process` itself. Any allocation or free inside `process` aborts the test binary
//! ("memory allocation of N bytes failed"), which fails the run.
//!
//! Only built with `--features rt-checks` (`Cargo.toml` `required-features`): the feature makes
//! nice-plug's checking allocator the global allocator, and the other plugin tests install a
//! counting allocator of their own.
//!
//! [`FitJob`]: tactus::plugin::fit_job::FitJob

#[path = "integration/common/mod.rs"]
mod common;
#[path = "integration/common/fit_harness.rs"]
mod fit_harness;

/// One `process` call inside nice-plug's checker; it aborts on an allocation, so a call that
/// returns made none.
fn checked(f: &mut dyn FnMut()) -> u64 {
    nice_assert_no_alloc::assert_no_alloc(f);
    0
}

// nice-plug installs its checker only in builds with debug assertions (its own `cfg`), and
// `nice-assert-no-alloc` is a no-op without them: a release run would check nothing.
#[test]
#[cfg_attr(
    not(debug_assertions),
    ignore = "SKIPPED: nice-plug checks allocations only with debug assertions (dev profile)"
)]
fn fitting_ten_recordings_under_assert_process_allocs() {
    fit_harness::fit_ten_while_processing(&checked);
}

/// Offline, every object is drawn in `process` (docs/plugin.md, "Where objects are drawn"):
/// the largest valid preset ([`tactus::preset::worst_case_preset`]), a new object in every
/// block through Seed, New Object and Material, at four block sizes. Each block's note plays the
/// object that block asks for.
#[test]
#[cfg_attr(
    not(debug_assertions),
    ignore = "SKIPPED: nice-plug checks allocations only with debug assertions (dev profile)"
)]
fn offline_worst_case_draws_under_assert_process_allocs() {
    use nice_plug::prelude::*;
    use std::collections::BTreeMap;
    use tactus::plugin::user_preset::USER_SLOT;

    let mut p = fit_harness::plugin(ProcessMode::Offline);
    let mut fields = BTreeMap::new();
    let json = tactus::preset::worst_case_preset().to_json();
    fields.insert("user_preset".to_string(), serde_json::to_string(&json).unwrap());
    p.params().deserialize_fields(&fields);
    fit_harness::set(&p, "material", USER_SLOT as f32);
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    for b in 0..12u32 {
        match b % 3 {
            0 => fit_harness::set(&p, "seed", (100 + b) as f32),
            1 => fit_harness::set(&p, "new_object", (b % 2) as f32),
            _ => fit_harness::set(&p, "material", if b % 2 == 0 { USER_SLOT as f32 } else { 0.0 }),
        }
        let len = [512, 64, 1, 333][b as usize % 4];
        let params = p.tactus_params();
        fit_harness::block(
            &mut p,
            &mut l[..len],
            &mut r[..len],
            vec![fit_harness::note(0, 60)],
            &checked,
        );
        let key = p.object_key();
        let seed = params.object_seed.load(std::sync::atomic::Ordering::Acquire);
        assert_eq!(
            key.seed, seed,
            "block {b}: the note did not get the object of its block"
        );
        assert_eq!(
            key.material,
            params.material.value() as usize,
            "block {b}: material"
        );
        assert!(l[..len].iter().chain(&r[..len]).all(|x| x.is_finite()));
    }
}

/// Gestures under the checker: Bounce, Break (64 fragments of the worst-case preset, drawn in
/// `process` offline) and Rattle notes, note-offs and chokes, with the gesture parameters
/// jumping between blocks, offline and in real time (where the worker draws the bodies).
#[test]
#[cfg_attr(
    not(debug_assertions),
    ignore = "SKIPPED: nice-plug checks allocations only with debug assertions (dev profile)"
)]
fn gestures_under_assert_process_allocs() {
    use nice_plug::midi::{Channel, Key, VoiceID};
    use nice_plug::prelude::*;
    use std::collections::BTreeMap;
    use tactus::plugin::user_preset::USER_SLOT;

    let off = |timing, key| NoteEvent::NoteOff {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Number(key),
        velocity: 0.0,
    };
    let choke = |timing| NoteEvent::Choke {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Wildcard,
    };
    for mode in [ProcessMode::Offline, ProcessMode::Realtime] {
        let mut p = fit_harness::plugin(mode);
        let mut fields = BTreeMap::new();
        let json = tactus::preset::worst_case_preset().to_json();
        fields.insert("user_preset".to_string(), serde_json::to_string(&json).unwrap());
        p.params().deserialize_fields(&fields);
        fit_harness::set(&p, "material", USER_SLOT as f32);
        fit_harness::set(&p, "gesture", 2.0);
        fit_harness::set(&p, "fragments", 64.0);
        let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
        for b in 0..40u32 {
            let len: usize = [512, 64, 1, 333][b as usize % 4];
            let mut events = vec![fit_harness::note(0, 60 + (b % 5) as u8)];
            match b % 8 {
                0 => fit_harness::set(&p, "gesture", (b / 8 % 4) as f32),
                1 => fit_harness::set(&p, "fragments", [1.0, 64.0, 16.0, 7.0][b as usize / 8 % 4]),
                2 => fit_harness::set(&p, "restitution", [0.0, 0.98][b as usize / 8 % 2]),
                3 => fit_harness::set(&p, "height", [0.01, 10.0][b as usize / 8 % 2]),
                4 => {
                    fit_harness::set(&p, "rattle_rate", [1.0, 100.0][b as usize / 8 % 2]);
                    fit_harness::set(&p, "spread", [0.0, 2.0][b as usize / 8 % 2]);
                }
                5 => events.push(off(len as u32 - 1, 60)),
                6 => fit_harness::set(&p, "material", [0.0, USER_SLOT as f32][b as usize / 8 % 2]),
                _ => events = vec![choke(0)],
            }
            fit_harness::block(&mut p, &mut l[..len], &mut r[..len], events, &checked);
            assert!(l[..len].iter().chain(&r[..len]).all(|x| x.is_finite()));
        }
    }
}

/// The output limiter's reducing path under the checker: every control at its maximum, the
/// worst-case preset, 64 notes at full velocity and every gesture (the integration test
/// `plugin_limiter` checks the samples; here, that limiting allocates nothing).
#[test]
#[cfg_attr(
    not(debug_assertions),
    ignore = "SKIPPED: nice-plug checks allocations only with debug assertions (dev profile)"
)]
fn limiting_the_loudest_setting_under_assert_process_allocs() {
    let mut p = fit_harness::loudest_plugin(true);
    let out = fit_harness::loudest_render(&mut p, &checked);
    assert!(p.take_limiter_min_gain() < 1.0, "the limiter never acted");
    assert!(out
        .iter()
        .all(|v| v.is_finite() && v.abs() <= tactus::engine::limiter::CEILING));
}

/// The editor's strike pad under the checker: presses and releases pushed between blocks (as
/// the editor's thread does), a full queue drained in one block, every gesture, offline and in
/// real time.
#[test]
#[cfg_attr(
    not(debug_assertions),
    ignore = "SKIPPED: nice-plug checks allocations only with debug assertions (dev profile)"
)]
fn strike_pad_under_assert_process_allocs() {
    use nice_plug::prelude::*;
    use tactus::plugin::strike_pad::{PadEvent, PAD_QUEUE_LEN};

    for mode in [ProcessMode::Offline, ProcessMode::Realtime] {
        let mut p = fit_harness::plugin(mode);
        fit_harness::set(&p, "fragments", 64.0);
        let pad = p.strike_pad();
        let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
        for b in 0..48u32 {
            let len: usize = [512, 64, 1, 333][b as usize % 4];
            if b % 12 == 0 {
                fit_harness::set(&p, "gesture", (b / 12 % 4) as f32);
            }
            match b % 6 {
                0 => assert!(pad.push(PadEvent::Press {
                    velocity: (b % 5) as f32 / 4.0
                })),
                3 => assert!(pad.push(PadEvent::Release)),
                5 => {
                    // A flood: the whole ring, drained by one block.
                    let mut queued = 0;
                    while pad.push(if queued % 2 == 0 {
                        PadEvent::Press { velocity: 1.0 }
                    } else {
                        PadEvent::Release
                    }) {
                        queued += 1;
                    }
                    assert_eq!(queued, PAD_QUEUE_LEN);
                }
                _ => {}
            }
            fit_harness::block(&mut p, &mut l[..len], &mut r[..len], Vec::new(), &checked);
            assert!(pad.is_empty(), "block {b} left pad events queued");
            assert!(l[..len].iter().chain(&r[..len]).all(|x| x.is_finite()));
        }
    }
}
