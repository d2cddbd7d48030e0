//! What happens at a sample offset inside a block: the engine's only timed input.

/// Something that happens at a sample offset inside the current block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// An impact.
    Impact {
        /// Sample offset inside the block.
        offset: u32,
        /// Impact speed, m/s.
        velocity_m_per_s: f64,
        /// Extra frequency factor for this hit (e.g. from a MIDI note), 1 = none.
        pitch_factor: f64,
        /// Identifier for choking (e.g. MIDI key), or −1.
        key: i32,
    },
    /// An impact on one of the engine's bodies (docs/model.md §11 "In the plugin"): a gesture's
    /// hit on the object, a fragment, dust or a rattling object.
    BodyImpact {
        /// Sample offset inside the block.
        offset: u32,
        /// 0: the current object; `k ≥ 1`: body `k` of [`super::Engine::draw_bodies`]. A body
        /// not drawn (yet) is played by the object at the hit's size, pitch and mass.
        body: u16,
        /// Impact speed, m/s.
        velocity_m_per_s: f64,
        /// Frequency factor of this hit (note pitch over the body's relative size), 1 = none.
        pitch_factor: f64,
        /// Contact mass relative to the mass setting (a fragment's share of the object's), in
        /// `1e-6..=1`: outside it the nearest bound, 1 when not finite (a body is never
        /// heavier than the object it came from).
        mass_factor: f64,
        /// Factor on the level of the hit's modes and transient per unit impulse (the body's
        /// [`super::gesture::Body::gain`]), in `0..=1e4`: outside it the nearest bound, 1 when
        /// not finite.
        gain: f64,
        /// Factor on the decay of the hit's modes (the body's
        /// [`super::gesture::Body::damping`]), in `1e-3..=1e3`: outside it the nearest bound, 1
        /// when not finite.
        damping_factor: f64,
        /// Least decay of the hit's modes, dB/s, after `damping_factor` (a piece of a broken
        /// object: [`super::gesture::PIECE_DECAY_DB_PER_S`]), in `0..=1e5`: outside it the
        /// nearest bound, 0 when not finite.
        min_decay_db_per_s: f64,
        /// Identifier for choking (e.g. MIDI key), or −1.
        key: i32,
    },
    /// The current object breaks (docs/model.md §11 "Break"): from here, every mode of the
    /// voices sounding it that were started with this key (−1: all) decays at least at
    /// [`super::gesture::FRACTURE_DECAY_DB_PER_S`]. Voices of gesture bodies, and hits after
    /// the fracture, are untouched. Comes after the strike that breaks the object (an impact
    /// at the same offset before it in the list).
    Fracture {
        /// Sample offset inside the block.
        offset: u32,
        /// Key of the voices that break.
        key: i32,
    },
    /// Silence the voices started with this key (−1: all).
    Choke {
        /// Sample offset inside the block.
        offset: u32,
        /// Key to choke.
        key: i32,
    },
    /// Draw a new object from the material's distribution with this seed.
    NewObject {
        /// Sample offset inside the block.
        offset: u32,
        /// Seed of the new object.
        seed: u64,
    },
}

impl Event {
    /// Sample offset inside the block.
    pub fn offset(&self) -> u32 {
        match *self {
            Event::Impact { offset, .. }
            | Event::BodyImpact { offset, .. }
            | Event::Fracture { offset, .. }
            | Event::Choke { offset, .. }
            | Event::NewObject { offset, .. } => offset,
        }
    }

    /// Moves the event to sample `offset` of its block.
    pub fn set_offset(&mut self, to: u32) {
        match self {
            Event::Impact { offset, .. }
            | Event::BodyImpact { offset, .. }
            | Event::Fracture { offset, .. }
            | Event::Choke { offset, .. }
            | Event::NewObject { offset, .. } => *offset = to,
        }
    }
}
