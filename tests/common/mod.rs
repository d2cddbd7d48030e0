//! Helpers shared by the integration tests that read the real recordings.

use std::path::PathBuf;

/// The recordings folder: `$TACTUS_RECORDINGS`, else `../shared/recordings` beside the checkout.
/// `None` (and a "SKIPPED" line on stderr) when it does not exist, so those tests skip.
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
