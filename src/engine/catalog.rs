//! The built-in materials as `tactus preset list` shows them: name (what a scene's `material`
//! and the plugin's `material` parameter take), class, origin and sources, in `material`
//! parameter order (the user slot left out: it holds no built-in material).

use super::materials;
use crate::preset::{Origin, Preset};
use serde::Serialize;

/// One built-in material.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Listed {
    /// Its index in the plugin's `material` parameter.
    pub index: usize,
    /// Display name.
    pub name: String,
    /// Material class.
    pub class: String,
    /// "recordings", "measured mode tables" or "derived".
    pub origin: &'static str,
    /// Recordings, mode tables or publications it came from.
    pub sources: Vec<String>,
}

/// What a preset's origin says, in the listing's words.
pub fn origin_words(origin: Origin) -> &'static str {
    match origin {
        Origin::Fitted => "recordings",
        Origin::Measured => "measured mode tables",
        Origin::Derived | Origin::Provisional => "derived",
    }
}

fn listed(index: usize, p: &Preset) -> Listed {
    Listed {
        index,
        name: p.name.clone(),
        class: p.material_class.clone(),
        origin: origin_words(p.origin),
        sources: p.provenance.sources.clone(),
    }
}

/// Every built-in material in `material` parameter order: the built-ins, (the user slot),
/// the object families, the measured materials.
pub fn builtin_list() -> Vec<Listed> {
    let builtin = materials::builtin_presets();
    let after_slot = builtin.len() + 1;
    builtin
        .iter()
        .enumerate()
        .map(|(i, p)| listed(i, p))
        .chain(
            materials::family_presets()
                .iter()
                .chain(&materials::measured_presets())
                .enumerate()
                .map(|(i, p)| listed(after_slot + i, p)),
        )
        .collect()
}

/// The listing as a text table; sources shortened to the first two and a count.
pub fn table(list: &[Listed]) -> String {
    let mut out = format!(
        "{:>5}  {:<30} {:<10} {:<21} {}\n",
        "index", "name", "class", "origin", "source"
    );
    for l in list {
        let source = match l.sources.len() {
            0 => String::new(),
            1 | 2 => l.sources.join("; "),
            n => format!("{}; {} … ({n} in all)", l.sources[0], l.sources[1]),
        };
        out.push_str(&format!(
            "{:>5}  {:<30} {:<10} {:<21} {source}\n",
            l.index, l.name, l.class, l.origin
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn names_are_unique_and_every_origin_appears() {
        let list = super::builtin_list();
        let mut names: Vec<String> = list.iter().map(|l| l.name.to_ascii_lowercase()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), list.len());
        for o in ["recordings", "measured mode tables", "derived"] {
            assert!(list.iter().any(|l| l.origin == o), "no {o}");
        }
    }
}
