//! Emits `cfg(tactus_no_recordings)` when the recordings folder that the recordings-based tests
//! (tests/fit_*.rs, tests/integration/eval.rs) read is missing, so those tests are marked ignored with the
//! reason "SKIPPED: recordings not found" in the test summary instead of passing silently.
//! The folder is `$TACTUS_RECORDINGS`, else `../shared/recordings` beside the checkout (as in
//! tests/common::recordings).

use std::path::PathBuf;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(tactus_no_recordings)");
    println!("cargo::rerun-if-env-changed=TACTUS_RECORDINGS");
    println!("cargo::rerun-if-changed=build.rs");
    let dir = std::env::var_os("TACTUS_RECORDINGS")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default())
                .join("../shared/recordings")
        });
    // Watch the folder, or its nearest existing ancestor while it is missing, so that a folder
    // appearing or vanishing is noticed. (Watching a missing path would rerun this script, and
    // rebuild the crate, on every cargo command.)
    let watched = dir.ancestors().find(|p| p.exists()).unwrap_or(&dir);
    println!("cargo::rerun-if-changed={}", watched.display());
    if !dir.is_dir() {
        println!("cargo::rustc-cfg=tactus_no_recordings");
    }
}
