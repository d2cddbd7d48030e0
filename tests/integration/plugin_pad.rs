//! The editor's strike pad (docs/plugin.md, "Strike pad") driven as the editor drives it: a
//! press pushed into the plugin's pad queue plays, through `process`, exactly what a host's
//! note-on of the pad's key at the same velocity plays at the block's first sample, and a
//! release what its note-off does, for every gesture; with the host's transport stopped (the
//! stub host's), and without an allocation on the audio thread.

use crate::counting_alloc::allocs;
use crate::fit_harness::{self, set, FS};
use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::*;
use tactus::plugin::strike_pad::{PadEvent, PAD_KEY};
use tactus::plugin::stub_host::StubHost;
use tactus::plugin::Tactus;

const BLOCK: usize = 512;
/// Block of the press and of its release.
const PRESS_BLOCK: usize = 3;
const RELEASE_BLOCK: usize = 40;

/// How a block's note reaches the plugin: as the pad's event or as the host's note.
#[derive(Clone, Copy)]
enum Via {
    Pad,
    Host,
}

fn host_note(event: PadEvent) -> NoteEvent<()> {
    let (voice_id, channel, key) = (VoiceID::Wildcard, Channel::Wildcard, Key::Number(PAD_KEY));
    match event {
        PadEvent::Press { velocity } => NoteEvent::NoteOn {
            timing: 0,
            voice_id,
            channel,
            key,
            velocity,
        },
        PadEvent::Release => NoteEvent::NoteOff {
            timing: 0,
            voice_id,
            channel,
            key,
            velocity: 0.0,
        },
    }
}

/// Wood with `gesture`, a press at `velocity` in block [`PRESS_BLOCK`] and its release in block
/// `release`, `via` the pad or the host, `blocks` blocks; both channels, and the allocations
/// `process` made.
fn render(
    mode: ProcessMode,
    gesture: f32,
    velocity: f32,
    via: Via,
    blocks: usize,
    release: usize,
) -> (Vec<f32>, Vec<f32>, u64) {
    let mut p: Tactus = fit_harness::plugin(mode);
    set(&p, "material", 0.0);
    set(&p, "gesture", gesture);
    set(&p, "fragments", 8.0);
    let pad = p.strike_pad();
    let (mut l, mut r) = (vec![0f32; blocks * BLOCK], vec![0f32; blocks * BLOCK]);
    let mut allocated = 0;
    for b in 0..blocks {
        let event = if b == PRESS_BLOCK {
            Some(PadEvent::Press { velocity })
        } else if b == release {
            Some(PadEvent::Release)
        } else {
            None
        };
        let mut notes = Vec::new();
        match (event, via) {
            (Some(e), Via::Pad) => assert!(pad.push(e), "the pad's queue refused a press"),
            (Some(e), Via::Host) => notes.push(host_note(e)),
            (None, _) => {}
        }
        let span = b * BLOCK..(b + 1) * BLOCK;
        allocated += fit_harness::block(&mut p, &mut l[span.clone()], &mut r[span], notes, &|f| {
            let before = allocs();
            f();
            allocs() - before
        });
        assert!(pad.is_empty(), "block {b} left pad events queued");
    }
    (l, r, allocated)
}

#[test]
fn a_pad_press_plays_what_a_note_on_of_its_velocity_plays() {
    assert!(
        !StubHost::new(FS).transport.playing,
        "the pad must play with the transport stopped"
    );
    let blocks = (1.5 * FS as f64) as usize / BLOCK;
    // Strike, Break, Rattle: one impact, a gesture of bodies, a gesture its note-off ends.
    for (gesture, name) in [(0.0, "Strike"), (2.0, "Break"), (3.0, "Rattle")] {
        for velocity in [0.3, 1.0] {
            for mode in [ProcessMode::Realtime, ProcessMode::Offline] {
                let (pl, pr, pad_allocs) = render(mode, gesture, velocity, Via::Pad, blocks, RELEASE_BLOCK);
                let (hl, hr, _) = render(mode, gesture, velocity, Via::Host, blocks, RELEASE_BLOCK);
                let what = format!("{name}, velocity {velocity}, {mode:?}");
                assert_eq!(pad_allocs, 0, "{what}: process allocated with pad events");
                let peak = pl.iter().fold(0f32, |m, v| m.max(v.abs()));
                assert!(peak > 1e-3, "{what}: the press played nothing (peak {peak})");
                let silent_before = pl[..PRESS_BLOCK * BLOCK].iter().all(|&v| v == 0.0);
                assert!(silent_before, "{what}: sound before the press");
                // In real time a gesture's bodies come from the worker whenever it is done, so
                // two real-time renders of a gesture need not agree; offline they must.
                if mode == ProcessMode::Offline || gesture == 0.0 {
                    assert!(pl == hl && pr == hr, "{what}: the pad and the host's note differ");
                }
            }
        }
    }
    // The release ends a rattle: in the last 0.5 s, far less sound than from a press still
    // held.
    let tail_energy = |release| {
        let (l, _, _) = render(ProcessMode::Offline, 3.0, 1.0, Via::Pad, blocks, release);
        l[l.len() - FS as usize / 2..]
            .iter()
            .map(|&v| v as f64 * v as f64)
            .sum::<f64>()
    };
    let (released, held) = (tail_energy(RELEASE_BLOCK), tail_energy(usize::MAX));
    assert!(
        released < 0.01 * held,
        "the rattle shakes on after the pad's release: tail energy {released} vs {held} held"
    );
}
