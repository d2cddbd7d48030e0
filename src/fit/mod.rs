//! Fitting material presets from recordings (docs/model.md §3–4): mode extraction
//! ([`extract`], after Traer et al. 2019 §2.1), damping-law fit ([`damping`], Sterling et al.
//! 2019 §1.2), pooled mode/transient distributions ([`distribution`]) and the `tactus fit` /
//! `tactus preset show` commands ([`cli`]), the `tactus eval` evaluation against recordings
//! ([`eval`], [`features`], [`spectrogram`]); [`traer`] is Traer's spectrogram matching, kept as the
//! baseline the shipped extractor is compared against.

pub mod audio;
pub mod bands;
pub mod cli;
pub mod damping;
pub mod density;
pub mod distribution;
pub mod draws;
pub mod eval;
pub mod extract;
pub mod family;
pub mod features;
pub mod labels;
mod lsq;
pub mod modes;
pub mod pipeline;
pub mod plot;
pub mod spectrogram;
pub mod traer;
