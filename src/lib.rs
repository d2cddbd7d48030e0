//! Tactus: physically based contact sounds (impacts, scraping, rolling) from a modal resonator
//! bank driven by contact-force generators. See `docs/model.md`.
//!
//! - [`engine`]: the DSP engine (no plugin or GUI types).
//! - [`preset`]: material presets (fitted mode distributions) and their validation.
//! - [`scene`]: offline scenes and rendering, used by the `tactus` CLI.
//! - [`fit`]: `tactus fit`, material presets fitted from recordings; [`eval`]: `tactus eval`,
//!   a preset's draws judged against labelled recordings; [`stats`]: the order statistics both use.
//! - [`perceptual`]: the ERB-band distance `bench` and `fit` judge renders by.
//! - [`plot_font`]: the font every plot's text is drawn in.
//! - [`batch`]: `tactus batch`, many variations of a scene into a folder with a manifest.
//! - [`plugin`]: the CLAP/VST3 wrapper, with its GUI in [`plugin::editor`] (egui, feature
//!   `editor`) and the editor's lock-free feed from the audio thread.

pub mod analysis;
pub mod batch;
pub mod bench;
pub mod engine;
pub mod eval;
pub mod fit;
pub mod perceptual;
pub mod plot_font;
pub mod plugin;
pub mod preset;
pub mod scene;
pub mod stats;
pub mod wav;
pub mod work;
