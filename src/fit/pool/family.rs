//! Which object family a recording belongs to, for `tactus fit --family-by` (docs/presets.md,
//! "Pooling into a preset"). A material such as wood is not one population of objects: marimba bars, wood
//! blocks and claves differ in mode count, spacing and damping, and one Gaussian over all of
//! them draws objects of no family (a bar's modes with a block's decays). Each family gets its
//! own distribution, and draws pick a family first.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::analysis::labels::normalise_label;
use crate::analysis::manifest::Manifest;

/// How recordings are grouped into families.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FamilyBy {
    /// `manifest` where a `manifest.csv` beside the file lists it, else `name` where the file
    /// name follows the convention, else one family for everything.
    #[default]
    Auto,
    /// The `instrument` column of the `manifest.csv` beside each file (columns `file` and
    /// `instrument`).
    Manifest,
    /// The file name `<material>_<family>_<anything>.wav`: the second `_`-separated field.
    Name,
    /// The name of the folder holding the file (one folder per family).
    Folder,
    /// No families: one distribution over all recordings.
    None,
}

impl std::str::FromStr for FamilyBy {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_lowercase().as_str() {
            "auto" => Ok(Self::Auto),
            "manifest" => Ok(Self::Manifest),
            "name" => Ok(Self::Name),
            "folder" => Ok(Self::Folder),
            "none" => Ok(Self::None),
            other => Err(format!(
                "unknown family grouping '{other}' (allowed: auto, manifest, name, folder, none)"
            )),
        }
    }
}

/// The family of each of `files` (same order); `None` when the files are not grouped (then one
/// distribution is fitted over all of them). Errors name the file and what is missing.
///
/// Labels are normalised as the evaluation's are ([`normalise_label`]): one drum kit's manifest
/// says "ride-cymbal" where another folder's says "ride cymbal", and as two families each would
/// weigh as much as every other family of the material.
pub fn families_of(files: &[PathBuf], by: FamilyBy) -> anyhow::Result<Option<Vec<String>>> {
    let mut manifests: HashMap<PathBuf, Option<HashMap<String, String>>> = HashMap::new();
    let mut manifest_family = |f: &Path| -> anyhow::Result<Option<String>> {
        let dir = f.parent().unwrap_or(Path::new(".")).to_path_buf();
        if !manifests.contains_key(&dir) {
            let m = read_manifest(&dir.join("manifest.csv"))?;
            manifests.insert(dir.clone(), m);
        }
        let name = file_name(f);
        Ok(manifests[&dir].as_ref().and_then(|m| m.get(&name).cloned()))
    };
    let out: Vec<String> = match by {
        FamilyBy::None => return Ok(None),
        FamilyBy::Manifest => files
            .iter()
            .map(|f| {
                manifest_family(f)?.ok_or_else(|| {
                    anyhow::anyhow!(
                        "{}: not listed with an instrument in {} (--family-by manifest)",
                        f.display(),
                        f.parent()
                            .unwrap_or(Path::new("."))
                            .join("manifest.csv")
                            .display()
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?,
        FamilyBy::Name => files
            .iter()
            .map(|f| {
                name_family(f).ok_or_else(|| {
                    anyhow::anyhow!(
                        "{}: file name is not <material>_<family>_<rest>.wav (--family-by name)",
                        f.display()
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?,
        FamilyBy::Folder => files
            .iter()
            .map(|f| {
                f.canonicalize()
                    .ok()
                    .and_then(|p| {
                        p.parent()
                            .and_then(|d| d.file_name())
                            .map(|n| n.to_string_lossy().into_owned())
                    })
                    .ok_or_else(|| {
                        anyhow::anyhow!("{}: cannot tell its folder (--family-by folder)", f.display())
                    })
            })
            .collect::<anyhow::Result<_>>()?,
        FamilyBy::Auto => {
            let mut v = Vec::with_capacity(files.len());
            for f in files {
                match manifest_family(f)?.or_else(|| name_family(f)) {
                    Some(n) => v.push(n),
                    // One file outside every convention: no grouping rather than a guess.
                    None => return Ok(None),
                }
            }
            v
        }
    };
    Ok(Some(out.iter().map(|f| normalise_label(f)).collect()))
}

/// The physical object each of `files` records (same order), for family-balanced weights
/// ([`crate::fit::pool::preset::balanced_weights`]): the `object_id` column of the `manifest.csv`
/// beside the file (velocity layers of one object share it), else the file itself.
pub fn objects_of(files: &[PathBuf]) -> anyhow::Result<Vec<String>> {
    let mut manifests: HashMap<PathBuf, HashMap<String, String>> = HashMap::new();
    files
        .iter()
        .map(|f| {
            let dir = f.parent().unwrap_or(Path::new(".")).to_path_buf();
            if !manifests.contains_key(&dir) {
                manifests.insert(dir.clone(), read_object_ids(&dir.join("manifest.csv"))?);
            }
            let name = file_name(f);
            Ok(manifests[&dir]
                .get(&name)
                .map(|o| format!("{}/{o}", dir.display()))
                .unwrap_or_else(|| f.display().to_string()))
        })
        .collect()
}

/// `file` → `object_id` of a manifest; empty without a manifest or that column.
fn read_object_ids(path: &Path) -> anyhow::Result<HashMap<String, String>> {
    let Some(m) = Manifest::read(path)? else {
        return Ok(HashMap::new());
    };
    if !m.has(&["file", "object_id"]) {
        return Ok(HashMap::new());
    }
    Ok(m.rows()
        .filter(|r| !r.file().is_empty() && !r.get("object_id").is_empty())
        .map(|r| (r.file().to_owned(), r.get("object_id").to_owned()))
        .collect())
}

fn file_name(f: &Path) -> String {
    f.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

/// Second `_`-separated field of the file stem, when there are at least three.
fn name_family(f: &Path) -> Option<String> {
    let stem = f.file_stem()?.to_string_lossy().into_owned();
    let parts: Vec<&str> = stem.split('_').collect();
    (parts.len() >= 3 && !parts[1].trim().is_empty()).then(|| parts[1].trim().to_owned())
}

/// `file` → `instrument` of a manifest (rows with an empty instrument left out); `Ok(None)`
/// when there is no manifest file.
fn read_manifest(path: &Path) -> anyhow::Result<Option<HashMap<String, String>>> {
    let Some(m) = Manifest::read(path)? else {
        return Ok(None);
    };
    m.require(&["instrument"]).map_err(|e| {
        anyhow::anyhow!("{e:#}; --family-by manifest needs the columns 'file' and 'instrument'")
    })?;
    Ok(Some(
        m.rows()
            .filter(|r| !r.get("instrument").is_empty())
            .map(|r| (r.file().to_owned(), r.get("instrument").to_owned()))
            .collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_groupings() {
        assert_eq!(
            name_family(Path::new("/r/wood_wood-block_fluidr3_high.wav")).as_deref(),
            Some("wood-block")
        );
        assert_eq!(name_family(Path::new("/r/clap.wav")), None);
        assert!("folders".parse::<FamilyBy>().unwrap_err().contains("allowed"));
    }

    #[test]
    fn spellings_of_one_family_are_one_family() {
        let dir = std::env::temp_dir().join(format!("tactus-family-spelling-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("manifest.csv"), "file,instrument\na.wav,Ride Cymbal\n").unwrap();
        let files = [dir.join("a.wav"), dir.join("metal_ride-cymbal_kit_b.wav")];
        let f = families_of(&files, FamilyBy::Auto).unwrap().unwrap();
        assert_eq!(f, ["ride cymbal", "ride cymbal"]);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn manifest_families_with_quotes_blank_instruments_and_missing_columns() {
        let dir = std::env::temp_dir().join(format!("tactus-family-manifest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("manifest.csv");
        std::fs::write(
            &path,
            "File,Material,Instrument\n\"a, b.wav\",wood,\"marimba \"\"low\"\"\"\nc.wav,wood,\nd.wav,wood, block \n",
        )
        .unwrap();
        let m = read_manifest(&path).unwrap().unwrap();
        assert_eq!(m.get("a, b.wav").map(String::as_str), Some("marimba \"low\""));
        assert_eq!(m.get("d.wav").map(String::as_str), Some("block"));
        assert!(!m.contains_key("c.wav"), "an empty instrument names no family");
        std::fs::write(&path, "file,material\na.wav,wood\n").unwrap();
        let e = format!("{:#}", read_manifest(&path).unwrap_err());
        assert!(e.contains("manifest.csv") && e.contains("`instrument`"), "{e}");
        assert!(read_manifest(&dir.join("absent.csv")).unwrap().is_none());
        std::fs::remove_dir_all(&dir).ok();
    }
}
