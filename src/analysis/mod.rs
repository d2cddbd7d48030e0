//! The analysis both fitting ([`crate::fit`]) and evaluation ([`crate::eval`]) stand on: what a
//! recording or a render is, measured the same way for both. It imports neither of them
//! (docs/architecture.md, checked by `tests/integration/architecture.rs`).
//!
//! - [`audio`]: reading a recording as mono f64, rejecting meaningless inputs.
//! - [`censoring`]: whether a recording ends before its sound has decayed (its decays are lower
//!   bounds), from its manifest or its signal.
//! - [`signal`]: modes and their energy, a strike's onset, DTFT tracks and decays.
//! - [`partials`]: the ringing partials read off a signal (prominent peaks tracked over time),
//!   band-energy decays, the spectral centroid.
//! - [`features`]: the perceptual features of one sound, for recordings and renders alike.
//! - [`manifest`]: the one reader of a recordings folder's `manifest.csv` (every column).
//! - [`labels`]: material and family labels of a folder of recordings.
//! - [`render`]: one hit on a drawn object through the real engine, as every judge hears it.

pub mod audio;
pub mod censoring;
pub mod features;
pub mod labels;
pub mod manifest;
pub mod partials;
pub mod render;
pub mod signal;
pub mod surfaces;
