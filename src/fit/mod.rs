//! Fitting material presets from recordings (docs/model.md §3–4): mode extraction
//! ([`extract`], after Traer et al. 2019 §2.1), damping-law fit ([`damping`], Sterling et al.
//! 2019 §1.2), pooled mode and transient distributions ([`distribution`], [`transient`]) and the
//! `tactus fit` / `tactus preset show` commands ([`cli`]); [`traer`] is Traer's spectrogram
//! matching, kept as the baseline the shipped extractor is compared against. The evaluation
//! against recordings (`tactus eval`) is [`crate::eval`], which builds on this module; the
//! module map with the dependency order is in docs/architecture.md.

pub mod audio;
pub mod bands;
pub mod cli;
pub mod damping;
pub mod density;
pub mod distribution;
pub mod extract;
pub mod family;
mod lsq;
pub mod manifest;
pub mod modes;
pub mod partials;
pub mod pipeline;
pub mod plot;
pub mod traer;
pub mod transient;
pub mod velocity;
