//! `tactus merge-manifests`: a sharded batch's manifests into one.

use std::path::PathBuf;

/// The arguments of `tactus merge-manifests`.
#[derive(clap::Args)]
pub struct Args {
    /// Batch output folder holding the shards' manifests.
    pub dir: PathBuf,
}

/// `tactus merge-manifests`.
pub fn run(a: Args) -> anyhow::Result<()> {
    let rows = tactus::batch::merge_manifests(&a.dir)?;
    eprintln!(
        "{}: merged {rows} rows into manifest.jsonl + manifest.csv",
        a.dir.display()
    );
    Ok(())
}
