//! The plugin editor: parameter groups, a strike pad that plays notes, a live view of the
//! object's modes, meters and a motion pad. [`feed`] (always compiled) is the lock-free channel the audio thread writes and
//! [`layout`] (always compiled) declares which parameters the editor draws; the egui editor
//! itself needs the `editor` feature.

pub mod feed;
pub mod layout;

#[cfg(feature = "editor")]
mod browser;
#[cfg(feature = "editor")]
mod displays;
#[cfg(feature = "editor")]
mod fit_panel;
#[cfg(feature = "editor")]
mod strike;
#[cfg(feature = "editor")]
mod style;
#[cfg(feature = "editor")]
mod view;

#[cfg(feature = "editor")]
pub use view::{create_editor, default_state, TactusEditor};
