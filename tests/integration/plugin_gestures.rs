//! The plugin's `gesture` parameter (docs/plugin.md, "Gestures"): what a note plays in Bounce,
//! Break and Rattle, measured on the audio `process` writes, as a host renders it.

use crate::common::onsets;
use crate::fit_harness::{self, set, unguarded, FS};
use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::*;
use tactus::plugin::Tactus;

const SR: f64 = FS as f64;

/// `gesture` parameter values (the enum's order).
const BOUNCE: f32 = 1.0;
const BREAK: f32 = 2.0;
const RATTLE: f32 = 3.0;

fn note_on(timing: u32, key: u8, velocity: f32) -> NoteEvent<()> {
    NoteEvent::NoteOn {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Number(key),
        velocity,
    }
}

fn note_off(timing: u32, key: u8) -> NoteEvent<()> {
    NoteEvent::NoteOff {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Number(key),
        velocity: 0.0,
    }
}

/// A plugin in `mode` on Wood (material 0) with `params` set.
fn wood_plugin(mode: ProcessMode, params: &[(&str, f32)]) -> Tactus {
    let p = fit_harness::plugin(mode);
    set(&p, "material", 0.0);
    for &(id, v) in params {
        set(&p, id, v);
    }
    p
}

/// [`wood_plugin`] rendering `seconds` in blocks of `block` samples with `notes` (timings in
/// samples from the start) placed in their blocks; the left channel.
fn render(
    mode: ProcessMode,
    params: &[(&str, f32)],
    notes: &[NoteEvent<()>],
    seconds: f64,
    block: usize,
) -> Vec<f32> {
    render_with(&mut wood_plugin(mode, params), notes, seconds, block)
}

fn render_with(p: &mut Tactus, notes: &[NoteEvent<()>], seconds: f64, block: usize) -> Vec<f32> {
    let total = (seconds * SR) as usize;
    let (mut out, mut r) = (vec![0f32; total], vec![0f32; block]);
    let mut pos = 0;
    while pos < total {
        let n = block.min(total - pos);
        let events: Vec<NoteEvent<()>> = notes
            .iter()
            .filter(|e| (pos..pos + n).contains(&(e.timing() as usize)))
            .map(|&(mut e)| {
                e.subtract_timing(pos as u32);
                e
            })
            .collect();
        fit_harness::block(p, &mut out[pos..pos + n], &mut r[..n], events, &unguarded);
        pos += n;
    }
    assert!(out.iter().all(|v| v.is_finite()));
    out
}

fn peak(x: &[f32]) -> f32 {
    x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

/// A Bounce note drops the object from Height: its impacts follow the restitution law (the
/// interval ratios of the first five are e) and fall in level, whatever the host's block size.
#[test]
fn a_bounce_note_follows_the_restitution_law() {
    let params = [("gesture", BOUNCE), ("height", 0.5), ("restitution", 0.6)];
    let notes = [note_on(4800, 60, 1.0)];
    let x = render(ProcessMode::Offline, &params, &notes, 1.6, 512);
    let on = onsets(&x, SR, 0.01);
    assert!(on.len() >= 5, "onsets {on:?}");
    assert!((on[0] - 0.1).abs() < 0.003, "first impact at the note: {on:?}");
    for w in on.windows(3).take(3) {
        let ratio = (w[2] - w[1]) / (w[1] - w[0]);
        assert!((ratio / 0.6 - 1.0).abs() < 0.05, "interval ratio {ratio}: {on:?}");
    }
    let peaks: Vec<f32> = on
        .windows(2)
        .take(4)
        .map(|w| peak(&x[(w[0] * SR) as usize..(w[1] * SR) as usize]))
        .collect();
    assert!(peaks.windows(2).all(|p| p[1] < p[0]), "peaks {peaks:?}");
    // Hits land on the same samples at any block size; the samples agree to f32 rounding (the
    // engine renders in chunks that end at block boundaries, for plain strikes too).
    let small = render(ProcessMode::Offline, &params, &notes, 1.6, 64);
    let diff = x
        .iter()
        .zip(&small)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(diff < 1e-5 * peak(&x), "block size changed the render by {diff}");
    // A softer note drops from lower: first impact quieter, bounces closer together.
    let soft = render(ProcessMode::Offline, &params, &[note_on(4800, 60, 0.5)], 1.6, 512);
    let soft_on = onsets(&soft, SR, 0.01);
    assert!(soft_on[1] - soft_on[0] < on[1] - on[0]);
}

/// A Break note: every fragment lands after the burst, each at its own time; the same project
/// renders the same samples twice offline, and in real time once the worker has drawn the
/// fragments (Wood's seven bodies are over a 512-sample block's draw budget).
#[test]
fn a_break_note_lands_its_fragments_and_renders_the_same_twice() {
    let params = [("gesture", BREAK), ("fragments", 6.0), ("restitution", 0.4)];
    let notes = [note_on(4800, 60, 1.0)];
    let x = render(ProcessMode::Offline, &params, &notes, 1.0, 512);
    let after = 0.1 + tactus::engine::gesture::BURST_S + 0.005;
    let on: Vec<f64> = onsets(&x, SR, 0.01).into_iter().filter(|&t| t > after).collect();
    assert!(on.len() >= 6, "{} onsets after the burst: {on:?}", on.len());
    assert!(x == render(ProcessMode::Offline, &params, &notes, 1.0, 512));

    let mut p = wood_plugin(ProcessMode::Realtime, &params);
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    let start = std::time::Instant::now();
    while p.body_count() < 7 {
        assert!(
            start.elapsed().as_secs() < 30,
            "the worker never delivered the fragments"
        );
        fit_harness::block(&mut p, &mut l, &mut r, vec![], &unguarded);
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    // As a host does at the start of a render: the engine's clock, on whose grid the masking
    // pass runs every 1024 samples, then starts where the offline render's did, whatever
    // number of blocks the worker took.
    p.reset();
    assert!(
        x == render_with(&mut p, &notes, 1.0, 512),
        "the worker's fragments differ"
    );
}

/// A Rattle note shakes while held: onsets at the Rattle Rate (within 20 %), none after the
/// note-off, silence after the ring-out.
#[test]
fn a_rattle_note_shakes_until_note_off() {
    let rate = 12.0;
    let params = [("gesture", RATTLE), ("fragments", 4.0), ("rattle_rate", rate)];
    let (from, to) = (0.5, 5.5);
    let notes = [
        note_on((from * SR) as u32, 60, 0.9),
        note_off((to * SR) as u32, 60),
    ];
    let x = render(ProcessMode::Offline, &params, &notes, 9.0, 512);
    let on = onsets(&x, SR, 0.01);
    assert!(
        on.iter().all(|&t| (from - 0.01..to + 0.01).contains(&t)),
        "{on:?}"
    );
    let measured = on.len() as f64 / (to - from);
    assert!(
        (measured / rate as f64 - 1.0).abs() < 0.2,
        "onset rate {measured}"
    );
    assert!(
        peak(&x[(8.0 * SR) as usize..]) < 1e-5,
        "silent after the ring-out"
    );
}

/// Strike (the default) plays one impact per note: the gesture machinery changes nothing.
#[test]
fn strike_notes_are_single_impacts() {
    let notes = [note_on(4800, 60, 1.0)];
    let x = render(ProcessMode::Offline, &[("gesture", 0.0)], &notes, 0.6, 512);
    assert_eq!(onsets(&x, SR, 0.01).len(), 1);
}

/// A Break note as the host tests play it (tests/host/test_gestures.py: Wood, full velocity,
/// the other parameters at their defaults), counted by the issue's onset detector
/// ([`crate::common::hf_onsets`]) for 4, 8 and 16 fragments, and the Spread parameter reaching
/// the gesture (a wider window moves the landings): at least one onset per fragment
/// (docs/model.md §11 "Break"). `--nocapture` prints the counts.
#[test]
fn a_break_note_counted_by_the_issues_detector_and_its_spread() {
    use crate::common::hf_onsets;
    let notes = [note_on(4800, 60, 1.0)];
    for n in [4.0, 8.0, 16.0] {
        let params = [("gesture", BREAK), ("fragments", n)];
        let x = render(ProcessMode::Offline, &params, &notes, 2.0, 512);
        let on = hf_onsets(&x, SR);
        println!("plugin Break, Wood, {n} fragments: {} onsets {on:?}", on.len());
        assert!(
            on.len() >= n as usize,
            "{n} fragments, {} onsets: {on:?}",
            on.len()
        );
    }
    let params = |spread| [("gesture", BREAK), ("fragments", 4.0), ("spread", spread)];
    let narrow = render(ProcessMode::Offline, &params(0.0), &notes, 2.0, 512);
    let wide = render(ProcessMode::Offline, &params(1.5), &notes, 2.0, 512);
    let last = |x: &[f32]| x.iter().rposition(|v| v.abs() > 1e-3).unwrap_or(0) as f64 / SR;
    assert!(
        last(&wide) > last(&narrow) + 0.5,
        "Spread 1.5 s ends at {} s, Spread 0 at {} s",
        last(&wide),
        last(&narrow)
    );
}
