//! Helpers shared by the integration tests (recordings folder, one rendered hit, a line fit). Each test
//! crate uses some of them, hence `allow(dead_code)`.
#![allow(dead_code)]

use std::path::PathBuf;

#[allow(unused_imports)]
pub use tactus::eval::draws::render_one_hit;

/// The recordings folder: `$TACTUS_RECORDINGS`, else `../shared/recordings` beside the checkout.
/// `None` (and a "SKIPPED" line on stderr) when it does not exist. Tests that need it are also
/// marked `#[cfg_attr(tactus_no_recordings, ignore = "SKIPPED: recordings not found")]` (build.rs
/// sets that cfg when the folder is missing at build time), so the summary shows them as ignored.
pub fn recordings() -> Option<PathBuf> {
    let dir = std::env::var_os("TACTUS_RECORDINGS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/recordings"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIPPED: recordings folder {} not found (set TACTUS_RECORDINGS)",
            dir.display()
        );
        None
    }
}

/// Least-squares slope of the line through `points` (x, y); NaN with fewer than two distinct x.
pub fn line_slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}
