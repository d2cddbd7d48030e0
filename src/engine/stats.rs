//! The engine's work counters.

/// Work counters, for benchmarks and the "skip what isn't needed" measurements.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stats {
    /// Mode-samples computed by the banks.
    pub mode_samples: u64,
    /// Band-samples computed by transients.
    pub band_samples: u64,
    /// Samples during which a contact force was computed.
    pub force_samples: u64,
    /// Voice-blocks processed (active voices × blocks).
    pub voice_blocks: u64,
    /// Blocks that took the idle fast path of [`Engine::process_with_speed`].
    pub idle_blocks: u64,
}
