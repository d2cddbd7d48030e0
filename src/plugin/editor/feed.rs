//! Lock-free data from the audio thread to the editor: the current object's modes (a seqlock of
//! atomics, written only when the object changes) and peak meters (atomic max-hold). The audio
//! side never allocates, locks or waits; the editor retries on a torn read.

use crate::engine::object::SampledObject;
use std::sync::atomic::{fence, AtomicU32, AtomicU64, Ordering};

/// Most modes shown by the editor; a larger object publishes its strongest ones.
pub const MAX_FEED_MODES: usize = 128;

/// One mode as the editor sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModePoint {
    /// Frequency in Hz (of the reference object, size 1).
    pub freq_hz: f32,
    /// Level in dB relative to the object's strongest mode.
    pub level_db: f32,
    /// Decay rate in dB/s.
    pub decay_db_per_s: f32,
}

/// Shared between the plugin (writer, audio thread) and the editor (reader, GUI thread).
pub struct EditorFeed {
    /// Seqlock counter: odd while the audio thread is writing the mode arrays.
    generation: AtomicU64,
    count: AtomicU32,
    freq: [AtomicU32; MAX_FEED_MODES],
    level: [AtomicU32; MAX_FEED_MODES],
    decay: [AtomicU32; MAX_FEED_MODES],
    /// Identity of the published object (material index, seed), audio thread only in practice.
    published_key: AtomicU64,
    published_material: AtomicU32,
    /// Output peak (linear, non-negative f32 bits) since the editor last took it.
    output_peak: AtomicU32,
    /// Contact-force peak in N (non-negative f32 bits) since the editor last took it.
    force_peak: AtomicU32,
    /// Whether any force peak has ever been published (the meter is hidden until then).
    force_seen: AtomicU32,
}

impl Default for EditorFeed {
    fn default() -> Self {
        Self {
            generation: AtomicU64::new(0),
            count: AtomicU32::new(0),
            freq: std::array::from_fn(|_| AtomicU32::new(0)),
            level: std::array::from_fn(|_| AtomicU32::new(0)),
            decay: std::array::from_fn(|_| AtomicU32::new(0)),
            published_key: AtomicU64::new(u64::MAX),
            published_material: AtomicU32::new(u32::MAX),
            output_peak: AtomicU32::new(0),
            force_peak: AtomicU32::new(0),
            force_seen: AtomicU32::new(0),
        }
    }
}

impl EditorFeed {
    /// Audio thread: publishes `object` if (material, seed) differs from what was last published.
    /// Allocation-free; O(modes × 128) only on a change.
    pub fn publish_object_if_changed(&self, material: usize, seed: u64, object: &SampledObject) {
        if self.published_key.load(Ordering::Relaxed) == seed
            && self.published_material.load(Ordering::Relaxed) == material as u32
        {
            return;
        }
        self.published_key.store(seed, Ordering::Relaxed);
        self.published_material.store(material as u32, Ordering::Relaxed);
        self.publish_object(object);
    }

    /// Audio thread: publishes the strongest [`MAX_FEED_MODES`] modes of `object`.
    pub fn publish_object(&self, object: &SampledObject) {
        // Strongest modes by level, kept in a fixed stack array (insertion into a sorted list).
        let mut top = [(f64::NEG_INFINITY, 0usize); MAX_FEED_MODES];
        let mut n = 0usize;
        for (i, m) in object.modes.iter().enumerate() {
            let l = if m.level_db.is_finite() {
                m.level_db
            } else {
                continue;
            };
            if n == MAX_FEED_MODES && l <= top[n - 1].0 {
                continue;
            }
            let mut j = n.min(MAX_FEED_MODES - 1);
            while j > 0 && top[j - 1].0 < l {
                top[j] = top[j - 1];
                j -= 1;
            }
            top[j] = (l, i);
            n = (n + 1).min(MAX_FEED_MODES);
        }
        let max_db = if n > 0 { top[0].0 } else { 0.0 };

        let g = self.generation.load(Ordering::Relaxed);
        self.generation.store(g.wrapping_add(1), Ordering::Relaxed);
        fence(Ordering::Release);
        for (k, &(_, i)) in top[..n].iter().enumerate() {
            let m = &object.modes[i];
            self.freq[k].store((m.freq_hz as f32).to_bits(), Ordering::Relaxed);
            self.level[k].store(((m.level_db - max_db) as f32).to_bits(), Ordering::Relaxed);
            self.decay[k].store((m.decay_db_per_s as f32).to_bits(), Ordering::Relaxed);
        }
        self.count.store(n as u32, Ordering::Relaxed);
        self.generation.store(g.wrapping_add(2), Ordering::Release);
    }

    /// Audio thread: raises the output peak (linear amplitude) to at least `peak`.
    pub fn publish_output_peak(&self, peak: f32) {
        if peak.is_finite() && peak > 0.0 {
            // For non-negative floats the bit patterns order like the values.
            self.output_peak.fetch_max(peak.to_bits(), Ordering::Relaxed);
        }
    }

    /// Audio thread: raises the contact-force peak (N) to at least `force_n`.
    pub fn publish_force_peak(&self, force_n: f32) {
        if force_n.is_finite() && force_n >= 0.0 {
            self.force_seen.store(1, Ordering::Relaxed);
            // −0.0 passes `>= 0.0`, but its bit pattern (sign bit set) is larger than every
            // positive float's and would win `fetch_max`; the peak starts at +0.0 already.
            if force_n > 0.0 {
                self.force_peak.fetch_max(force_n.to_bits(), Ordering::Relaxed);
            }
        }
    }

    /// Editor: the current generation (changes whenever new modes are published).
    pub fn generation(&self) -> u64 {
        self.generation.load(Ordering::Acquire)
    }

    /// Editor: copies the published modes into `out`. Returns the generation read, or `None` if
    /// the audio thread was writing (try again next frame).
    pub fn read_modes(&self, out: &mut Vec<ModePoint>) -> Option<u64> {
        let g1 = self.generation.load(Ordering::Acquire);
        if g1 % 2 == 1 {
            return None;
        }
        out.clear();
        let n = (self.count.load(Ordering::Relaxed) as usize).min(MAX_FEED_MODES);
        for k in 0..n {
            out.push(ModePoint {
                freq_hz: f32::from_bits(self.freq[k].load(Ordering::Relaxed)),
                level_db: f32::from_bits(self.level[k].load(Ordering::Relaxed)),
                decay_db_per_s: f32::from_bits(self.decay[k].load(Ordering::Relaxed)),
            });
        }
        fence(Ordering::Acquire);
        (self.generation.load(Ordering::Relaxed) == g1).then_some(g1)
    }

    /// Editor: takes (and resets) the output peak since the last call.
    pub fn take_output_peak(&self) -> f32 {
        f32::from_bits(self.output_peak.swap(0, Ordering::Relaxed))
    }

    /// Editor: takes (and resets) the contact-force peak since the last call; `None` until the
    /// engine has ever reported a force.
    pub fn take_force_peak(&self) -> Option<f32> {
        (self.force_seen.load(Ordering::Relaxed) != 0)
            .then(|| f32::from_bits(self.force_peak.swap(0, Ordering::Relaxed)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::object::ObjectMode;

    fn object(n: usize) -> SampledObject {
        let mut o = SampledObject::with_capacity();
        o.modes.clear();
        for i in 0..n {
            o.modes.push(ObjectMode {
                freq_hz: 100.0 * (i + 1) as f64,
                level_db: -(i as f64),
                decay_db_per_s: 10.0 + i as f64,
                rise_s: 0.0,
                ring: Default::default(),
                inverted: false,
            });
        }
        o
    }

    #[test]
    fn publishes_strongest_modes_relative_to_max() {
        let feed = EditorFeed::default();
        feed.publish_object_if_changed(0, 1, &object(300));
        let mut out = Vec::new();
        let g = feed.read_modes(&mut out).expect("no concurrent writer");
        assert_eq!(g % 2, 0);
        assert_eq!(out.len(), MAX_FEED_MODES);
        assert_eq!(out[0].level_db, 0.0);
        assert!(out.iter().all(|m| m.freq_hz <= 100.0 * MAX_FEED_MODES as f32));
        // Same object again: nothing republished.
        feed.publish_object_if_changed(0, 1, &object(3));
        assert_eq!(feed.generation(), g);
        feed.publish_object_if_changed(0, 2, &object(3));
        assert_ne!(feed.generation(), g);
        feed.read_modes(&mut out).unwrap();
        assert_eq!(out.len(), 3);
    }

    #[test]
    fn peaks_are_max_hold_and_reset_on_take() {
        let feed = EditorFeed::default();
        feed.publish_output_peak(0.25);
        feed.publish_output_peak(0.5);
        feed.publish_output_peak(0.1);
        assert_eq!(feed.take_output_peak(), 0.5);
        assert_eq!(feed.take_output_peak(), 0.0);
        assert_eq!(feed.take_force_peak(), None);
        feed.publish_force_peak(3.0);
        assert_eq!(feed.take_force_peak(), Some(3.0));
        feed.publish_force_peak(2.0);
        feed.publish_force_peak(-0.0);
        assert_eq!(feed.take_force_peak(), Some(2.0), "−0.0 must not mask a force");
        feed.publish_force_peak(-0.0);
        let zero = feed.take_force_peak().unwrap();
        assert_eq!(zero.to_bits(), 0.0f32.to_bits(), "a −0.0 force reads as +0");
    }
}
