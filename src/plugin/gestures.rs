//! What a note does when the `gesture` parameter is Bounce, Break or Rattle (docs/plugin.md,
//! "Gestures"): it starts an engine gesture ([`crate::engine::gesture`]), whose hits this player
//! turns into [`Event::BodyImpact`]s at their samples, block by block (a break's strike followed
//! by its [`Event::Fracture`]). Hits land on the engine's
//! bodies ([`crate::engine::bodies`]): the object itself, or the fragments, dust and rattling
//! objects drawn for it off the audio thread.
//!
//! Real-time safe: the slots are allocated once ([`GesturePlayer::new`]); starting a gesture
//! writes a fixed-size generator into a slot, and hits go into a buffer of fixed capacity (a hit
//! that does not fit waits for the next block, never lost).

use crate::engine::gesture::{Gesture, GestureKind, Hit};
use crate::engine::Event;

/// Most gestures sounding at once; a new one beyond that replaces the oldest.
pub const MAX_GESTURES: usize = 16;

/// A gesture in flight.
#[derive(Clone)]
struct Slot {
    gesture: Gesture,
    /// The generator's next hit, not yet played.
    next: Option<Hit>,
    /// Player clock (samples) of the gesture's time 0.
    start: u64,
    /// Player clock at which the gesture stops generating hits (note-off of a rattle, choke).
    end: u64,
    /// MIDI key (choke, note-off).
    key: i32,
    /// The note's frequency factor.
    pitch: f64,
    /// Whether a note-off ends it (rattle).
    held: bool,
}

/// The gestures of the plugin's notes.
pub struct GesturePlayer {
    slots: Vec<Option<Slot>>,
    /// Hits of the current block, sorted by offset (capacity fixed at construction).
    hits: Vec<Event>,
    /// Samples since [`GesturePlayer::reset`] at the start of the current block.
    clock: u64,
    /// Gestures started since reset: the seed of the next one, so a render from reset is the
    /// same every time.
    started: u64,
    sample_rate_hz: f64,
}

impl GesturePlayer {
    /// A player with room for `max_hits` hits per block (at least 2: a strike and its
    /// fracture; allocates).
    pub fn new(max_hits: usize) -> Self {
        Self {
            slots: vec![None; MAX_GESTURES],
            hits: Vec::with_capacity(max_hits.max(2)),
            clock: 0,
            started: 0,
            sample_rate_hz: 48_000.0,
        }
    }

    /// Silence and a new clock at `sample_rate_hz`.
    pub fn reset(&mut self, sample_rate_hz: f64) {
        self.slots.iter_mut().for_each(|s| *s = None);
        self.hits.clear();
        self.clock = 0;
        self.started = 0;
        if sample_rate_hz.is_finite() && sample_rate_hz > 0.0 {
            self.sample_rate_hz = sample_rate_hz;
        }
    }

    /// Whether a gesture may still generate hits.
    pub fn any_active(&self) -> bool {
        self.slots.iter().any(Option::is_some)
    }

    /// Starts `kind` at sample `offset` of the current block, for MIDI key `key` at frequency
    /// factor `pitch`; `seed` is mixed with the number of gestures since reset. A rattle runs
    /// until [`GesturePlayer::release`] of its key (or its own duration).
    pub fn start(&mut self, kind: GestureKind, offset: u32, key: i32, pitch: f64, seed: u64) {
        self.started += 1;
        let seed = seed ^ self.started.wrapping_mul(0x9E37_79B9_7F4A_7C15);
        let mut gesture = Gesture::new(kind, seed);
        let next = gesture.next();
        let slot = Slot {
            gesture,
            next,
            start: self.clock + offset as u64,
            end: u64::MAX,
            key,
            pitch,
            held: matches!(kind, GestureKind::Rattle(_)),
        };
        let i = self
            .slots
            .iter()
            .position(Option::is_none)
            .unwrap_or_else(|| self.oldest());
        self.slots[i] = Some(slot);
    }

    fn oldest(&self) -> usize {
        (0..self.slots.len())
            .min_by_key(|&i| self.slots[i].as_ref().map_or(0, |s| s.start))
            .unwrap_or(0)
    }

    /// Note-off of `key` (−1: all) at `offset`: its rattles stop shaking there (their hits
    /// ring out).
    pub fn release(&mut self, key: i32, offset: u32) {
        let at = self.clock + offset as u64;
        for s in self.slots.iter_mut().flatten() {
            if s.held && (key < 0 || s.key == key) {
                s.end = s.end.min(at);
            }
        }
    }

    /// Choke of `key` (−1: all) at `offset`: its gestures stop there.
    pub fn choke(&mut self, key: i32, offset: u32) {
        let at = self.clock + offset as u64;
        for s in self.slots.iter_mut().flatten() {
            if key < 0 || s.key == key {
                s.end = s.end.min(at);
            }
        }
    }

    /// The hits of the next `len` samples as events (offsets in the block, sorted), and moves
    /// the clock past the block.
    pub fn block(&mut self, len: u32) -> &[Event] {
        self.hits.clear();
        let block_end = self.clock + len as u64;
        let last = len.saturating_sub(1);
        let sr = self.sample_rate_hz;
        for cell in self.slots.iter_mut() {
            let Some(slot) = cell else { continue };
            while let Some(hit) = slot.next {
                let at = slot.start + (hit.t_s * sr).round() as u64;
                if at >= slot.end {
                    slot.next = None;
                    break;
                }
                // A fracture follows its strike in the same block: both fit, or both wait.
                let room = 1 + hit.fracture as usize;
                if at >= block_end || self.hits.len() + room > self.hits.capacity() {
                    break;
                }
                let body = &slot.gesture.bodies()[hit.body];
                let offset = (at.saturating_sub(self.clock) as u32).min(last);
                self.hits.push(Event::BodyImpact {
                    offset,
                    // The object's own hits (its seed) sound the object; the others name their
                    // body, which the engine holds in gesture order.
                    body: if body.seed.is_some() { hit.body as u16 } else { 0 },
                    velocity_m_per_s: hit.velocity_m_per_s,
                    pitch_factor: slot.pitch * hit.pitch_factor / body.size,
                    mass_factor: body.mass,
                    gain: body.gain,
                    damping_factor: body.damping,
                    min_decay_db_per_s: body.min_decay_db_per_s,
                    key: slot.key,
                });
                if hit.fracture {
                    self.hits.push(Event::Fracture {
                        offset,
                        key: slot.key,
                    });
                }
                slot.next = slot.gesture.next();
            }
            if slot.next.is_none() {
                *cell = None;
            }
        }
        // At one offset a fracture comes after the impacts: it damps the strike it follows
        // (an unstable sort on the offset alone could put it first; a stable one may allocate).
        self.hits
            .sort_unstable_by_key(|e| (e.offset(), matches!(e, Event::Fracture { .. })));
        self.clock = block_end;
        &self.hits
    }

    /// Moves the clock past a block in which no gesture sounds.
    pub fn skip(&mut self, len: u32) {
        self.clock += len as u64;
    }
}

/// Merges `a` and `b` (each sorted by offset) into `out` (cleared; at most its capacity),
/// `a` first at equal offsets. Never allocates.
pub fn merge_events(a: &[Event], b: &[Event], out: &mut Vec<Event>) {
    out.clear();
    let (mut i, mut j) = (0, 0);
    while out.len() < out.capacity() && (i < a.len() || j < b.len()) {
        let take_a = j == b.len() || (i < a.len() && a[i].offset() <= b[j].offset());
        if take_a {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::gesture::{BounceParams, BreakParams, RattleParams};

    fn offsets_and_bodies(p: &mut GesturePlayer, blocks: usize, len: u32) -> Vec<(u64, u16)> {
        let mut out = Vec::new();
        for b in 0..blocks {
            for e in p.block(len) {
                if let Event::BodyImpact { offset, body, .. } = *e {
                    out.push((b as u64 * len as u64 + offset as u64, body));
                }
            }
        }
        out
    }

    #[test]
    fn hits_land_where_the_generator_puts_them_whatever_the_block_size() {
        let kind = GestureKind::Break(BreakParams {
            fragments: 5,
            ..Default::default()
        });
        let run = |len: u32| {
            let mut p = GesturePlayer::new(64);
            p.reset(48_000.0);
            p.start(kind, 7, 60, 1.0, 3);
            offsets_and_bodies(&mut p, 48_000 / len as usize, len)
        };
        let a = run(64);
        assert_eq!(a, run(512));
        assert_eq!(a, run(1));
        assert!(a.iter().any(|&(_, b)| b == 0), "the object is struck");
        for k in 2..7 {
            assert!(a.iter().any(|&(_, b)| b == k), "fragment {k} never lands");
        }
        assert_eq!(a[0].0, 7, "the strike is at the note");
    }

    #[test]
    fn a_full_hit_buffer_delays_hits_to_the_next_block_and_loses_none() {
        let kind = GestureKind::Break(BreakParams {
            fragments: 64,
            ..Default::default()
        });
        let count = |cap: usize| {
            let mut p = GesturePlayer::new(cap);
            p.reset(48_000.0);
            p.start(kind, 0, 60, 1.0, 3);
            offsets_and_bodies(&mut p, 400, 480).len()
        };
        assert_eq!(count(4), count(4096));
    }

    #[test]
    fn note_off_ends_a_rattle_and_choke_ends_any_gesture() {
        let rattle = GestureKind::Rattle(RattleParams {
            duration_s: 3600.0,
            ..Default::default()
        });
        let mut p = GesturePlayer::new(256);
        p.reset(48_000.0);
        p.start(rattle, 0, 60, 1.0, 1);
        assert!(!offsets_and_bodies(&mut p, 10, 4800).is_empty());
        p.release(60, 100);
        let after = offsets_and_bodies(&mut p, 1, 4800);
        assert!(
            after.iter().all(|&(t, _)| t < 100),
            "rattle hit after note-off: {after:?}"
        );
        assert!(offsets_and_bodies(&mut p, 10, 4800).is_empty());
        assert!(!p.any_active());
        p.start(GestureKind::Bounce(BounceParams::default()), 0, 61, 1.0, 1);
        p.release(61, 0);
        assert!(
            offsets_and_bodies(&mut p, 10, 4800).len() > 1,
            "note-off ended a bounce"
        );
        p.choke(-1, 0);
        assert!(offsets_and_bodies(&mut p, 20, 4800).is_empty());
        assert!(!p.any_active());
    }

    #[test]
    fn merge_keeps_both_orders_and_the_first_list_first() {
        let at = |offset, key| Event::Choke { offset, key };
        let mut out = Vec::with_capacity(8);
        merge_events(&[at(0, 1), at(5, 2)], &[at(0, 3), at(2, 4), at(9, 5)], &mut out);
        let keys: Vec<i32> = out
            .iter()
            .map(|e| match e {
                Event::Choke { key, .. } => *key,
                _ => unreachable!(),
            })
            .collect();
        assert_eq!(keys, [1, 3, 4, 2, 5]);
    }
}
