//! The plugin's own `process` driven without a host (`plugin::stub_host`): no allocation on the
//! audio thread with the largest valid user preset and parameter jumps, where objects are drawn
//! (a costly draw off the audio thread in real-time mode, in `process` when rendering offline
//! or when the draw is cheap), the idle block.

use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::*;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};
use tactus::plugin::stub_host::StubHost;
use tactus::plugin::Tactus;
use tactus::preset::worst_case_preset;

use crate::counting_alloc::allocs;
// The stub host's blocks, parameter changes and notes, shared with the plugin fit's harness.
use crate::fit_harness::{self, note, set};

/// A plugin, activated at 48 kHz with blocks of up to `max_block`, in `mode`.
fn plugin(max_block: u32, mode: ProcessMode) -> Tactus {
    let mut p = Tactus::default();
    assert!(StubHost::new(48_000.0).activate(&mut p, 48_000.0, max_block, mode));
    p
}

fn user_preset(p: &Tactus, json: String) {
    let mut fields = BTreeMap::new();
    fields.insert("user_preset".to_string(), serde_json::to_string(&json).unwrap());
    p.params().deserialize_fields(&fields);
}

/// One block through the plugin's `process` (the fit harness's stub-host block); returns the
/// allocations it made on this thread.
fn block(p: &mut Tactus, l: &mut [f32], r: &mut [f32], events: Vec<NoteEvent<()>>) -> u64 {
    fit_harness::block(p, l, r, events, &|f| {
        let before = allocs();
        f();
        allocs() - before
    })
}

/// Material index of the user preset slot in the `material` parameter.
const USER: f32 = tactus::plugin::user_preset::USER_SLOT as f32;

#[test]
fn worst_case_user_preset_and_parameter_jumps_never_allocate() {
    let mut p = plugin(512, ProcessMode::Realtime);
    user_preset(&p, worst_case_preset().to_json());
    set(&p, "material", USER);
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    let mut installed = 0;
    for b in 0..200u32 {
        // Every 10th block a new object is asked for (seed, new_object trigger or material),
        // and every parameter jumps.
        if b % 10 == 0 {
            set(&p, "seed", (1 + b) as f32);
            set(&p, "new_object", (b % 20 == 0) as u8 as f32);
            set(&p, "material", if b % 30 == 0 { 0.0 } else { USER });
            for (id, v) in [
                ("size", 0.1 + (b % 7) as f32),
                ("damping", (b % 5) as f32),
                ("scrape_speed", (b % 3) as f32),
                ("roll_speed", (b % 4) as f32 * 0.5),
                ("quality", 20.0 + (b % 11) as f32 * 20.0),
                ("gain", -30.0 + (b % 6) as f32 * 9.0),
                // Width jumps between mono, the default and full width (0 switches the
                // engine's mono path on once the ramp ends, anything else the stereo one).
                ("width", [0.0, 0.5, 1.0, 0.0, 0.3][(b / 10) as usize % 5]),
            ] {
                set(&p, id, v);
            }
        }
        let len = [512, 64, 1, 333][b as usize % 4];
        let before = p.object_key();
        let n = block(
            &mut p,
            &mut l[..len],
            &mut r[..len],
            vec![note(0, 40 + (b % 40) as u8)],
        );
        assert_eq!(n, 0, "allocation in process, block {b}");
        assert!(l[..len].iter().chain(&r[..len]).all(|x| x.is_finite()));
        if b % 50 == 9 {
            // Width 0 since block b − 9, its ramp long over: identical channels.
            assert!(l[..len] == r[..len], "width 0, block {b}: channels differ");
        }
        if p.object_key() != before {
            installed += 1;
        }
        // Give the worker time to draw (a real host calls process every block period). Before
        // the next request, wait up to 1 s of empty blocks for this one's object: a loaded
        // machine (other tests, a build) can keep the worker from its core for longer than ten
        // block periods, which would count a late object as a missing one.
        std::thread::sleep(Duration::from_millis(2));
        if b % 10 == 9 {
            let t0 = std::time::Instant::now();
            let mut key = p.object_key();
            while installed < (b / 10 + 1) as usize && t0.elapsed() < Duration::from_secs(1) {
                std::thread::sleep(Duration::from_millis(5));
                let n = block(&mut p, &mut l[..64], &mut r[..64], Vec::new());
                assert_eq!(n, 0, "allocation in process, waiting after block {b}");
                if p.object_key() != key {
                    installed += 1;
                    key = p.object_key();
                }
            }
        }
    }
    assert!(
        installed >= 10,
        "only {installed} objects arrived from the worker"
    );
}

/// Every mode building up: each hit starts `MAX_MODES` resonators (pairs), and re-hits merge
/// them, with no allocation.
#[test]
fn build_up_pairs_at_the_mode_cap_never_allocate() {
    pairs_at_the_mode_cap_never_allocate(
        tactus::preset::worst_case_build_up_preset(),
        ProcessMode::Realtime,
    );
}

/// Every mode ringing after its knock, its objects drawn within `process` (offline): as the
/// build-ups, with no allocation.
#[test]
fn ring_pairs_drawn_offline_never_allocate() {
    pairs_at_the_mode_cap_never_allocate(tactus::preset::worst_case_ring_preset(), ProcessMode::Offline);
}

fn pairs_at_the_mode_cap_never_allocate(preset: tactus::preset::Preset, mode: ProcessMode) {
    let mut p = plugin(512, mode);
    user_preset(&p, preset.to_json());
    set(&p, "material", USER);
    set(&p, "quality", 300.0);
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    for b in 0..120u32 {
        if b % 30 == 0 {
            set(&p, "seed", (1 + b) as f32);
        }
        let len = [512, 64, 1, 333][b as usize % 4];
        let n = block(
            &mut p,
            &mut l[..len],
            &mut r[..len],
            vec![note(0, 40 + (b % 3) as u8)],
        );
        assert_eq!(n, 0, "allocation in process, block {b}");
        assert!(l[..len].iter().chain(&r[..len]).all(|x| x.is_finite()));
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn realtime_process_leaves_a_costly_draw_to_the_worker() {
    let mut p = plugin(256, ProcessMode::Realtime);
    user_preset(&p, worst_case_preset().to_json());
    set(&p, "material", USER);
    let (mut l, mut r) = (vec![0f32; 256], vec![0f32; 256]);
    let old = p.object_key();
    assert_eq!(block(&mut p, &mut l, &mut r, Vec::new()), 0);
    // The block that first sees the request cannot have the object: it was only posted.
    assert_eq!(p.object_key(), old, "the audio thread drew the object itself");
    let start = Instant::now();
    while p.object_key() == old {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "the worker never delivered"
        );
        std::thread::sleep(Duration::from_millis(1));
        assert_eq!(block(&mut p, &mut l, &mut r, Vec::new()), 0);
    }
    let key = p.object_key();
    assert_eq!(key.material, tactus::plugin::user_preset::USER_SLOT);
    assert_eq!(key.seed, tactus::plugin::DEFAULT_SEED);
    assert!(key.library > 0, "drawn from the loaded preset, not the fallback");
}

/// The worst-case preset's draw is too costly for a real-time block, so the worker draws it;
/// offline `process` draws it in place. Both give the same object: the renders after it are
/// identical.
#[test]
fn offline_process_draws_in_place_and_matches_the_worker() {
    let render = |mode: ProcessMode| {
        let mut p = plugin(256, mode);
        user_preset(&p, worst_case_preset().to_json());
        set(&p, "material", USER);
        set(&p, "seed", 4242.0);
        let (mut l, mut r) = (vec![0f32; 256], vec![0f32; 256]);
        let mut out = Vec::new();
        // Real-time: wait for the worker before the note, offline: the first block has it.
        let start = Instant::now();
        loop {
            assert_eq!(block(&mut p, &mut l, &mut r, Vec::new()), 0);
            if p.object_key().seed == 4242 {
                break;
            }
            assert!(
                mode == ProcessMode::Realtime,
                "offline process did not draw in place"
            );
            assert!(start.elapsed() < Duration::from_secs(10));
            std::thread::sleep(Duration::from_millis(1));
        }
        // Same engine time and hit RNG for both renders from here on.
        p.reset();
        for b in 0..8 {
            let ev = if b == 0 { vec![note(3, 60)] } else { Vec::new() };
            assert_eq!(block(&mut p, &mut l, &mut r, ev), 0);
            out.extend_from_slice(&l);
        }
        out
    };
    let offline = render(ProcessMode::Offline);
    assert!(offline.iter().any(|x| x.abs() > 1e-4));
    let realtime = render(ProcessMode::Realtime);
    let diff = offline
        .iter()
        .zip(&realtime)
        .fold(0f32, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        offline == realtime,
        "worker and in-place draws differ by up to {diff}"
    );
}

/// Renders 12 blocks of 512 samples: an empty lead-in block, then `change` (a parameter set as
/// a host sets it between blocks), then a note at sample 3 of the next block.
fn note_after_change(mode: ProcessMode, before_lead_in: bool, change: &dyn Fn(&Tactus)) -> Vec<f32> {
    let mut p = plugin(512, mode);
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    if before_lead_in {
        change(&p);
    }
    assert_eq!(block(&mut p, &mut l, &mut r, Vec::new()), 0);
    if !before_lead_in {
        change(&p);
    }
    let mut out = Vec::new();
    for b in 0..12 {
        let ev = if b == 0 { vec![note(3, 60)] } else { Vec::new() };
        assert_eq!(block(&mut p, &mut l, &mut r, ev), 0);
        out.extend(l.iter().zip(&r).flat_map(|(a, b)| [*a, *b]));
    }
    out
}

/// A change of Material, Seed or New Object whose draw fits the block's budget (every shipped
/// material at 512 samples) takes effect in the block that brings it, in real-time mode as
/// offline: the note in that block plays the new object, sample for sample as a render that
/// starts with it, whatever the worker's timing (a host that renders faster than real time
/// without saying so gets the same audio).
#[test]
fn a_cheap_draw_plays_in_the_block_that_brings_it_in_every_mode() {
    let next = tactus::plugin::params::next_seed(tactus::plugin::DEFAULT_SEED) as f32;
    let changes: [(&str, &dyn Fn(&Tactus), &dyn Fn(&Tactus)); 3] = [
        ("material", &|p| set(p, "material", 0.0), &|p| {
            set(p, "material", 0.0)
        }),
        ("seed", &|p| set(p, "seed", 777.0), &|p| set(p, "seed", 777.0)),
        ("new_object", &|p| set(p, "new_object", 1.0), &move |p| {
            set(p, "seed", next)
        }),
    ];
    let unchanged = note_after_change(ProcessMode::Offline, false, &|_| {});
    for (name, change, reference) in changes {
        let starts_with = note_after_change(ProcessMode::Offline, true, reference);
        assert!(
            starts_with != unchanged,
            "{name}: the change does not change the sound"
        );
        for mode in [ProcessMode::Offline, ProcessMode::Realtime] {
            let changed = note_after_change(mode, false, change);
            assert!(
                changed == starts_with,
                "{name}, {mode:?}: the note after the change does not play the new object"
            );
        }
    }
}

#[test]
fn a_user_preset_over_the_mode_limit_is_refused_by_name() {
    let mut over = worst_case_preset();
    if let tactus::preset::ModeModel::Distribution(d) = &mut over.modes {
        d.count = tactus::engine::limits::MAX_DISTRIBUTION_MODES + 1;
        d.gaussian.mean.resize(3 * d.count, 0.0);
    }
    let slot = tactus::plugin::user_preset::UserPresetSlot::default();
    let err = slot.set_json(over.to_json()).unwrap_err();
    assert!(
        err.contains("modes.count") && err.contains("129") && err.contains("1..=128"),
        "{err}"
    );
    assert_eq!(slot.status(), err);
}

fn cc1(value: f32) -> NoteEvent<()> {
    NoteEvent::MidiCC {
        timing: 0,
        channel: 0,
        cc: tactus::plugin::CC_SCRAPE_SPEED,
        value,
    }
}

/// An idle plugin block takes the engine's idle fast path, through the plugin's own `process`:
/// before any note, after a hit has rung out, and with a scrape speed the mod wheel turns to 0.
#[test]
fn an_idle_plugin_takes_the_engine_idle_path() {
    let mut p = plugin(64, ProcessMode::Realtime);
    let (mut l, mut r) = (vec![0f32; 64], vec![0f32; 64]);
    let mut run = |p: &mut Tactus, blocks: usize, first: Vec<NoteEvent<()>>| {
        p.take_engine_stats();
        let mut ev = first;
        for _ in 0..blocks {
            assert_eq!(block(p, &mut l, &mut r, std::mem::take(&mut ev)), 0);
        }
        p.take_engine_stats().idle_blocks
    };
    assert_eq!(run(&mut p, 100, Vec::new()), 100, "a fresh plugin is not idle");
    // A hit is not idle; once every voice is asleep the plugin is idle again. A drawn cymbal's
    // slowest partials ring for tens of seconds before they fall under the sleep floor
    // (−110 dBFS), so the test waits for that, second by second, up to a minute.
    assert_eq!(run(&mut p, 10, vec![note(0, 60)]), 0);
    let rang_out = (1..=60).find(|_| run(&mut p, 750, Vec::new()) == 750);
    eprintln!("default hit asleep within {rang_out:?} s");
    assert!(rang_out.is_some(), "not idle 60 s after the hit");
    assert_eq!(
        run(&mut p, 100, Vec::new()),
        100,
        "idle again after the hit rang out"
    );
    // Scraping at 1 m/s is not idle; the mod wheel at 0 stops it (in the block that moves it:
    // speed and wheel are read once, after the block's MIDI), and once the scraping bank has
    // rung out the plugin is idle.
    set(&p, "scrape_speed", 1.0);
    assert_eq!(run(&mut p, 100, Vec::new()), 0, "scraping took the idle path");
    run(&mut p, 6 * 750, vec![cc1(0.0)]);
    assert_eq!(run(&mut p, 100, Vec::new()), 100, "mod wheel at 0 still scrapes");
}

/// The idle shortcut leaves silent outputs whatever the host's buffers held: nice-plug does not
/// clear an instrument's output channels (it zero-fills only channels beyond a main input's),
/// so a host that hands over stale samples, −0.0, NaN or subnormals must get +0.0 back.
#[test]
fn an_idle_plugin_block_silences_dirty_host_buffers() {
    let mut p = plugin(64, ProcessMode::Realtime);
    let (mut l, mut r) = (vec![0f32; 64], vec![0f32; 64]);
    for dirt in [0.5f32, -0.0, f32::NAN, f32::MIN_POSITIVE / 4.0, f32::INFINITY] {
        l.fill(dirt);
        r[17] = dirt;
        p.take_engine_stats();
        assert_eq!(block(&mut p, &mut l, &mut r, Vec::new()), 0);
        assert_eq!(p.take_engine_stats().idle_blocks, 1, "not the idle path");
        assert!(
            l.iter().chain(&r).all(|v| v.to_bits() == 0),
            "outputs not +0.0 after a block over {dirt:?}"
        );
    }
}

fn note_off(timing: u32) -> NoteEvent<()> {
    NoteEvent::NoteOff {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Number(60),
        velocity: 0.0,
    }
}

/// The plugin's idle block (no events: its shortcut past the per-block settings) renders exactly
/// what its full path renders: two plugins get the same parameter changes while idle (smoothed
/// and not, during and after their ramps), one with no events, the other with a note-off in
/// every block (ignored, but it makes `process` take the full path); then both are hit and
/// scrape. Every sample must match, and both must have taken the engine's idle path equally.
#[test]
fn parameter_changes_while_idle_play_on_the_next_hit_as_in_the_full_path() {
    let changes: [(usize, &str, f32); 6] = [
        (3, "scrape_pressure", 20.0),
        // Alone, so the idle blocks of its ramp take the shortcut with the gain smoothing.
        (20, "gain", -12.0),
        (5, "size", 1.5),
        (5, "roughness", 0.9),
        (40, "damping", 0.5),
        (41, "roll_pressure", 8.0),
    ];
    let render = |with_note_offs: bool| {
        let mut p = plugin(64, ProcessMode::Realtime);
        let (mut l, mut r) = (vec![1f32; 64], vec![1f32; 64]);
        let mut out = Vec::new();
        let mut idle_blocks = 0;
        for b in 0..120 {
            for &(at, id, v) in &changes {
                if at == b {
                    set(&p, id, v);
                }
            }
            if b == 100 {
                set(&p, "scrape_speed", 0.5);
            }
            let mut events = Vec::new();
            if b == 90 || b == 110 {
                events.push(note(7, 64));
            }
            if with_note_offs {
                events.push(note_off(9));
            }
            assert_eq!(block(&mut p, &mut l, &mut r, events), 0);
            out.extend_from_slice(&l);
            out.extend_from_slice(&r);
            idle_blocks += p.take_engine_stats().idle_blocks;
        }
        (out, idle_blocks)
    };
    let (idle, idle_blocks) = render(false);
    let (full, full_blocks) = render(true);
    assert!(idle.iter().any(|&v| v != 0.0), "the hits must sound");
    assert_eq!(idle_blocks, full_blocks);
    // The 90 blocks before the first hit are idle.
    assert!(idle_blocks >= 90, "only {idle_blocks} idle blocks");
    let first_diff = idle
        .iter()
        .zip(&full)
        .position(|(a, b)| a.to_bits() != b.to_bits());
    assert_eq!(first_diff, None, "idle-block and full-path renders differ");
}
