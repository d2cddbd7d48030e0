//! Switches that turn the engine's savings off, for the benchmark's "nothing skipped" reference
//! and for tests that compare a saving against the full computation. Production code leaves
//! them at their defaults (all on).

/// What the engine may skip or add. Default: everything on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EngineOptions {
    /// Whether modes and noise bands are culled (static `quality` cut at the hit, dynamic
    /// retirement of decayed, inaudible and masked modes; docs/model.md §8). Off = every mode
    /// below Nyquist runs until its voice sleeps.
    pub culling: bool,
    /// Whether a re-hit of the same object (same tuning and key) re-excites the voice that still
    /// rings from the previous hit instead of stacking a second copy of its modes (see
    /// [`super::Engine::set_merging_enabled`]).
    pub merging: bool,
    /// Whether impacts start the noise-band transient (the `h_T` of docs/model.md §2).
    pub transient: bool,
}

impl Default for EngineOptions {
    fn default() -> Self {
        Self {
            culling: true,
            merging: true,
            transient: true,
        }
    }
}
