//! The editor's strike pad to the audio thread: a fixed-size single-producer single-consumer
//! ring of atomics. The editor (GUI thread, the one producer) pushes a press with its velocity
//! or a release; `process` drains the ring at the start of each block and plays each entry as a
//! MIDI note-on or note-off of [`PAD_KEY`] at the block's first sample, through the same code
//! as the host's notes (docs/plugin.md, "Strike pad"). Neither side allocates, locks or waits,
//! and nothing depends on the host's transport: hosts call `process` while stopped too.

use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::NoteEvent;
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};

/// The key the pad plays: middle C, frequency factor 1 in either note mode, so the pad sounds
/// the object at its own pitch.
pub const PAD_KEY: u8 = 60;

/// Entries the ring holds. A click is two entries and the audio thread empties the ring every
/// block (a few ms), so only a stalled audio thread fills it; a push into a full ring fails
/// instead of blocking.
pub const PAD_QUEUE_LEN: usize = 64;

/// Code of a release in a slot: a NaN with the sign bit set, never the bits of a velocity
/// (velocities are stored clamped to `0..=1`).
const RELEASE: u32 = u32::MAX;

/// What the pad did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PadEvent {
    /// Pressed: a note-on at `velocity` (0..=1, as a MIDI note's).
    Press {
        /// Note velocity, 0..=1.
        velocity: f32,
    },
    /// Released: a note-off (ends a rattle; impacts ring out).
    Release,
}

impl PadEvent {
    fn code(self) -> u32 {
        match self {
            PadEvent::Press { velocity } if velocity.is_finite() => velocity.clamp(0.0, 1.0).to_bits(),
            PadEvent::Press { .. } => 0.0f32.to_bits(),
            PadEvent::Release => RELEASE,
        }
    }

    fn from_code(code: u32) -> Self {
        if code == RELEASE {
            PadEvent::Release
        } else {
            PadEvent::Press {
                velocity: f32::from_bits(code),
            }
        }
    }
}

/// The ring. `head` counts pushes (written by the producer only), `tail` pops (by the consumer
/// only); both wrap, and their difference is the fill.
pub struct PadQueue {
    slots: [AtomicU32; PAD_QUEUE_LEN],
    head: AtomicUsize,
    tail: AtomicUsize,
}

impl Default for PadQueue {
    fn default() -> Self {
        Self {
            slots: std::array::from_fn(|_| AtomicU32::new(0)),
            head: AtomicUsize::new(0),
            tail: AtomicUsize::new(0),
        }
    }
}

impl PadQueue {
    /// Producer (the editor): queues `event`; false when the ring is full (the event is not
    /// queued).
    pub fn push(&self, event: PadEvent) -> bool {
        let head = self.head.load(Ordering::Relaxed);
        let tail = self.tail.load(Ordering::Acquire);
        if head.wrapping_sub(tail) >= PAD_QUEUE_LEN {
            return false;
        }
        self.slots[head % PAD_QUEUE_LEN].store(event.code(), Ordering::Relaxed);
        // Release: the slot's store is visible before the consumer sees the new head.
        self.head.store(head.wrapping_add(1), Ordering::Release);
        true
    }

    /// Consumer (the audio thread): the oldest queued event, if any.
    pub fn pop(&self) -> Option<PadEvent> {
        let tail = self.tail.load(Ordering::Relaxed);
        let head = self.head.load(Ordering::Acquire);
        if tail == head {
            return None;
        }
        let code = self.slots[tail % PAD_QUEUE_LEN].load(Ordering::Relaxed);
        // Release: the slot is read before the producer may reuse it.
        self.tail.store(tail.wrapping_add(1), Ordering::Release);
        Some(PadEvent::from_code(code))
    }

    /// Whether nothing is queued (either side; a snapshot).
    pub fn is_empty(&self) -> bool {
        self.head.load(Ordering::Acquire) == self.tail.load(Ordering::Acquire)
    }
}

/// The velocity of a press at `x` (0 = the pad's left edge, 1 = its right edge): the position
/// itself, at least 1/127 (MIDI's softest note-on) so that every press sounds.
pub fn velocity_at(x: f32) -> f32 {
    if x.is_finite() {
        x.clamp(1.0 / 127.0, 1.0)
    } else {
        1.0 / 127.0
    }
}

/// The note a strike pad event plays: a note-on or note-off of [`PAD_KEY`] at the block's
/// first sample, on any channel and voice (as a host's note without note ids).
pub fn note(event: PadEvent) -> NoteEvent<()> {
    let key = Key::Number(PAD_KEY);
    let (voice_id, channel) = (VoiceID::Wildcard, Channel::Wildcard);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_come_out_in_order_and_a_full_ring_refuses() {
        let q = PadQueue::default();
        assert!(q.is_empty() && q.pop().is_none());
        for round in 0..3 {
            for i in 0..PAD_QUEUE_LEN {
                let e = if i % 2 == 0 {
                    PadEvent::Press {
                        velocity: i as f32 / PAD_QUEUE_LEN as f32,
                    }
                } else {
                    PadEvent::Release
                };
                assert!(q.push(e), "round {round}, push {i}");
            }
            assert!(!q.push(PadEvent::Release), "a full ring took an event");
            for i in 0..PAD_QUEUE_LEN {
                let want = if i % 2 == 0 {
                    PadEvent::Press {
                        velocity: i as f32 / PAD_QUEUE_LEN as f32,
                    }
                } else {
                    PadEvent::Release
                };
                assert_eq!(q.pop(), Some(want));
            }
            assert!(q.is_empty() && q.pop().is_none());
        }
    }

    #[test]
    fn velocities_are_clamped_and_never_read_as_a_release() {
        let q = PadQueue::default();
        for v in [f32::NAN, -1.0, 2.0, f32::INFINITY, -0.0] {
            q.push(PadEvent::Press { velocity: v });
            let Some(PadEvent::Press { velocity }) = q.pop() else {
                panic!("{v} came out as a release")
            };
            assert!((0.0..=1.0).contains(&velocity), "{v} → {velocity}");
        }
        assert_eq!(velocity_at(0.0), 1.0 / 127.0);
        assert_eq!(velocity_at(0.5), 0.5);
        assert_eq!(velocity_at(3.0), 1.0);
        assert_eq!(velocity_at(f32::NAN), 1.0 / 127.0);
    }

    #[test]
    fn a_producer_thread_and_a_consumer_thread_agree() {
        let q = std::sync::Arc::new(PadQueue::default());
        let n = 20_000u32;
        let producer = {
            let q = q.clone();
            std::thread::spawn(move || {
                for i in 0..n {
                    let e = PadEvent::Press {
                        velocity: i as f32 / n as f32,
                    };
                    while !q.push(e) {
                        std::hint::spin_loop();
                    }
                }
            })
        };
        let mut got = 0u32;
        while got < n {
            if let Some(e) = q.pop() {
                assert_eq!(
                    e,
                    PadEvent::Press {
                        velocity: got as f32 / n as f32
                    }
                );
                got += 1;
            }
        }
        producer.join().unwrap();
        assert!(q.is_empty());
    }
}
