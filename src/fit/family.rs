//! Which object family a recording belongs to, for `tactus fit --family-by` (docs/presets.md,
//! "Families"). A material such as wood is not one population of objects: marimba bars, wood
//! blocks and claves differ in mode count, spacing and damping, and one Gaussian over all of
//! them draws objects of no family (a bar's modes with a block's decays). Each family gets its
//! own distribution, and draws pick a family first.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

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
    Ok(Some(out))
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

/// `file` → `instrument` of a manifest; `Ok(None)` when there is no manifest file.
fn read_manifest(path: &Path) -> anyhow::Result<Option<HashMap<String, String>>> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => anyhow::bail!("{}: cannot read ({e})", path.display()),
    };
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header = csv_fields(lines.next().unwrap_or_default());
    let col = |name: &str| header.iter().position(|h| h.trim().eq_ignore_ascii_case(name));
    let (Some(fc), Some(ic)) = (col("file"), col("instrument")) else {
        anyhow::bail!(
            "{}: needs the columns 'file' and 'instrument' to name families",
            path.display()
        );
    };
    let mut map = HashMap::new();
    for line in lines {
        let f = csv_fields(line);
        if let (Some(file), Some(inst)) = (f.get(fc), f.get(ic)) {
            if !inst.trim().is_empty() {
                map.insert(file.trim().to_owned(), inst.trim().to_owned());
            }
        }
    }
    Ok(Some(map))
}

/// Fields of one CSV line (RFC 4180 quoting: `"a, b"` and `""` inside quotes).
fn csv_fields(line: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    out.push(cur);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_and_names() {
        assert_eq!(csv_fields(r#"a,"b, c",d"#), vec!["a", "b, c", "d"]);
        assert_eq!(csv_fields(r#""x ""y""",z"#), vec![r#"x "y""#, "z"]);
        assert_eq!(
            name_family(Path::new("/r/wood_wood-block_fluidr3_high.wav")).as_deref(),
            Some("wood-block")
        );
        assert_eq!(name_family(Path::new("/r/clap.wav")), None);
        assert!("folders".parse::<FamilyBy>().unwrap_err().contains("allowed"));
    }
}
