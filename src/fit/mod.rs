//! Fitting material presets from recordings (docs/model.md §3–4), in the order the data flows:
//!
//! 1. [`recording`]: one recording → its modes, strike noise and ringing partials
//!    ([`recording::fit_file`]): mode extraction (after Traer et al. 2019 §2.1), the joint least
//!    squares, what counts as a mode, the noise-band transient, the dense-field candidates.
//! 2. [`pool`]: fitted recordings → a preset ([`pool::Pooling`]): families, the damping law
//!    (Sterling et al. 2019 §1.2), mode and transient distributions, dense fields, the contact
//!    exponent fitted to velocity layers.
//! 3. [`run`]: many files fitted in parallel, files that fail left out with their reason,
//!    progress and cancellation through one [`crate::progress::Observer`]; [`error`] says why a
//!    fit stopped.
//!
//! [`table`] reads measured mode tables (or a FEM tool's) and pools them as fitted
//! recordings are pooled.
//!
//! [`traer`] is Traer's spectrogram matching, kept as the baseline the shipped extractor is
//! compared against; [`plot`] draws `tactus fit --plot`. Everything here stands on
//! [`crate::analysis`] and never reads [`crate::eval`] (docs/architecture.md).

pub mod error;
pub mod plot;
pub mod pool;
pub mod recording;
pub mod run;
pub mod table;
pub mod traer;
