//! The typeface every plot draws its text in (`tactus fit --plot`, `tactus eval
//! --spectrograms`, `tactus bench`). plotters lays out SVG text and rasterises PNG text through
//! ab_glyph, which reads no system fonts, so plots look the same on every machine and need no
//! fontconfig; the font is egui's bundled Ubuntu Light (`epaint_default_fonts`, Ubuntu Font
//! Licence), registered once under [`FAMILY`] before a chart is built.

use std::sync::OnceLock;

/// The family name plots ask for.
pub const FAMILY: &str = "sans-serif";

/// Registers the font under [`FAMILY`] (once; later calls return the first result).
pub fn register() -> Result<(), &'static str> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(
            FAMILY,
            plotters::style::FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .is_ok()
    });
    ok.then_some(()).ok_or("the bundled plot font does not parse")
}
