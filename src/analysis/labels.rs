//! Labels of a folder of recordings (material class, object family), from a `manifest.csv`
//! beside the files or from their names (`<material>_<family>_….wav`).

use crate::analysis::audio;
use crate::analysis::manifest::Manifest;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A recording with its labels.
#[derive(Debug, Clone, Serialize)]
pub struct Labelled {
    /// Path of the recording.
    #[serde(skip)]
    pub path: PathBuf,
    /// File name.
    pub name: String,
    /// Material class, lower case (e.g. "wood").
    pub material: String,
    /// Object family, lower case with spaces (e.g. "wood block").
    pub family: String,
}

/// An input left out, with the reason in words.
#[derive(Debug, Clone, Serialize)]
pub struct Skipped {
    /// File name (or preset and seed for a draw).
    pub name: String,
    /// Why it was left out.
    pub reason: String,
}

/// Lower case, `-`/`_` as spaces, trimmed: "Wood-Block" and "wood block" are one family.
pub fn normalise_label(s: &str) -> String {
    s.trim()
        .to_lowercase()
        .replace(['-', '_'], " ")
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}

/// Labels the recordings of `dir` (named as [`audio::EXTENSIONS`] lists): from `manifest.csv`
/// beside them (columns `file`, `material`, `instrument`) when present, else from the name
/// `<material>_<family>_….wav` (any recording extension).
/// Files with neither are returned as skipped. Errors name the folder or manifest.
pub fn label_folder(dir: &Path) -> anyhow::Result<(Vec<Labelled>, Vec<Skipped>)> {
    if !dir.is_dir() {
        anyhow::bail!("{}: not a folder of recordings", dir.display());
    }
    let mut wavs: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| anyhow::anyhow!("{}: cannot read folder ({e})", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && audio::has_recording_extension(p))
        .collect();
    wavs.sort();
    if wavs.is_empty() {
        anyhow::bail!(
            "{}: no recordings ({}) in the folder",
            dir.display(),
            audio::FORMATS
        );
    }
    let manifest = read_manifest(&dir.join("manifest.csv"))?;
    let mut labelled = Vec::new();
    let mut skipped = Vec::new();
    for path in wavs {
        let name = file_name(&path);
        let from_name = || {
            let stem = path.file_stem()?.to_string_lossy().into_owned();
            let mut parts = stem.split('_');
            let (m, f) = (parts.next()?, parts.next()?);
            (!m.is_empty() && !f.is_empty()).then(|| (normalise_label(m), normalise_label(f)))
        };
        match manifest.get(&name).cloned().or_else(from_name) {
            Some((material, family)) => labelled.push(Labelled {
                path,
                name,
                material,
                family,
            }),
            None => skipped.push(Skipped {
                name,
                reason: "no labels: not in manifest.csv and not named <material>_<family>_….wav".into(),
            }),
        }
    }
    Ok((labelled, skipped))
}

/// `file → (material, family)` from a manifest; empty when the file does not exist.
fn read_manifest(path: &Path) -> anyhow::Result<BTreeMap<String, (String, String)>> {
    let mut out = BTreeMap::new();
    let Some(m) = Manifest::read(path)? else {
        return Ok(out);
    };
    m.require(&["material", "instrument"])?;
    for row in m.rows() {
        let (file, material, family) = (row.file(), row.get("material"), row.get("instrument"));
        if file.is_empty() || material.is_empty() || family.is_empty() {
            anyhow::bail!(
                "{}: line {}: empty file, material or instrument",
                path.display(),
                row.line
            );
        }
        out.insert(
            file.to_owned(),
            (normalise_label(material), normalise_label(family)),
        );
    }
    Ok(out)
}

pub fn file_name(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_normalise() {
        assert_eq!(normalise_label(" Wood-Block "), "wood block");
        assert_eq!(normalise_label("steel_drum"), "steel drum");
    }
}
