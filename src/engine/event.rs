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
            Event::Impact { offset, .. } | Event::Choke { offset, .. } | Event::NewObject { offset, .. } => {
                offset
            }
        }
    }
}
