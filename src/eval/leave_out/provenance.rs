//! What the recordings' manifests say of each recording for a leave-one-out evaluation: whether
//! its decay was edited (faded, cut while loud), which recording it is a gain copy of, its kit
//! and its velocity layer.

use crate::analysis::labels::normalise_label;
use crate::analysis::manifest::Manifest;
use std::collections::BTreeMap;
use std::path::Path;

/// A recording that ends still ringing louder than this (dB re its peak) is truncated.
const TRUNCATED_ABOVE_DB: f64 = -40.0;

/// How a manifest says a recording was edited, and which recording it is a gain copy of.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Provenance {
    /// Ends in an editor fade or is cut while still loud: its decay is not the object's.
    pub edited: bool,
    /// Whether it ends before its sound has decayed, by the manifest's end condition
    /// ([`crate::analysis::censoring::from_manifest`]); `None` where the manifest does not say.
    pub censored: Option<bool>,
    /// The file whose recording this is (a layer scaled by a constant gain), if any.
    pub same_recording_as: Option<String>,
    /// The manifest's `kit`: the drum kit or sound bank the recording comes from.
    pub kit: Option<String>,
    /// The manifest's `object_id` and `layer_index`: which velocity layer of which object.
    pub layer: Option<(String, i64)>,
}

/// `file → Provenance` from the `manifest.csv` in `dir` (columns `end_condition`,
/// `end_level_db_re_peak`, `same_recording_as`, `kit`, `object_id`, `layer_index` where present). The DEV manifest words a fade
/// "editor fade-out" and a truncation "sample ends while still decaying (last level −N dB re
/// peak)"; the kits' manifest says "fade found", and gives the end level in its own column.
pub fn read_provenance(dir: &Path) -> anyhow::Result<BTreeMap<String, Provenance>> {
    let mut out = BTreeMap::new();
    let Some(m) = Manifest::of_folder(dir)? else {
        return Ok(out);
    };
    if m.column("file").is_none() {
        return Ok(out);
    }
    for row in m.rows() {
        let end = row.get("end_condition").to_lowercase();
        let level = row.get("end_level_db_re_peak").parse::<f64>().ok().or_else(|| {
            let at = end.find("last level ")? + "last level ".len();
            end[at..]
                .split_whitespace()
                .next()?
                .replace('−', "-")
                .parse()
                .ok()
        });
        let still = end.contains("still decaying");
        let edited = end.contains("fade") || (still && level.is_some_and(|l| l > TRUNCATED_ABOVE_DB));
        let (same, kit, object) = (row.get("same_recording_as"), row.get("kit"), row.get("object_id"));
        let layer = row.get("layer_index").parse::<i64>().ok();
        out.insert(
            row.file().to_owned(),
            Provenance {
                edited,
                censored: crate::analysis::censoring::from_manifest(
                    row.get("end_condition"),
                    row.get("end_level_db_re_peak").parse().ok(),
                ),
                same_recording_as: (!same.is_empty()).then(|| same.to_owned()),
                kit: (!kit.is_empty()).then(|| kit.to_owned()),
                layer: layer
                    .filter(|_| !object.is_empty())
                    .map(|l| (object.to_owned(), l)),
            },
        );
    }
    Ok(out)
}

/// [`read_provenance`] of every folder in `dirs`, keyed by each recording's path
/// ([`provenance_key`]).
pub fn read_provenances(dirs: &[std::path::PathBuf]) -> anyhow::Result<BTreeMap<String, Provenance>> {
    let mut prov = BTreeMap::new();
    for d in dirs {
        for (file, p) in read_provenance(d)? {
            prov.insert(provenance_key(&d.join(file)), p);
        }
    }
    Ok(prov)
}

/// The key of the recording at `path` in a map of provenances gathered from several folders.
pub(super) fn provenance_key(path: &Path) -> String {
    path.display().to_string()
}

/// The provenance of the recording at `path`, if a manifest lists it.
pub(super) fn provenance<'a>(prov: &'a BTreeMap<String, Provenance>, path: &Path) -> Option<&'a Provenance> {
    prov.get(&provenance_key(path))
}

/// The kit of a recording: the manifest's `kit`, else the third `_` field of a name
/// `<material>_<family>_<kit>_….wav` (the recordings folders' naming; any recording extension),
/// else the file itself.
pub fn kit_of(name: &str, prov: Option<&Provenance>) -> String {
    if let Some(k) = prov.and_then(|p| p.kit.as_deref()) {
        return normalise_label(k);
    }
    let stem = match name.rsplit_once('.') {
        Some((stem, _)) if crate::analysis::audio::has_recording_extension(Path::new(name)) => stem,
        _ => name,
    };
    match stem.split('_').nth(2) {
        Some(k) if stem.split('_').count() > 3 => normalise_label(k),
        _ => stem.to_owned(),
    }
}

/// Whether the recording at `path` is fitted: a velocity layer of a layered object only when it
/// is that object's hardest (highest `layer_index` in its folder's manifest), as
/// `presets/refit.sh` fits the shipped presets from the strike nearest the default hit that
/// fitted levels are compensated for; a recording without layers always. The contact exponent
/// still learns from every layer ([`crate::fit::pool::velocity`]).
pub fn fitted_layer(path: &Path, prov: &BTreeMap<String, Provenance>) -> bool {
    let Some((object, layer)) = provenance(prov, path).and_then(|p| p.layer.as_ref()) else {
        return true;
    };
    let dir = path.parent();
    let top = prov
        .iter()
        .filter(|(k, _)| Path::new(k.as_str()).parent() == dir)
        .filter_map(|(_, p)| p.layer.as_ref())
        .filter(|(o, _)| o == object)
        .map(|(_, l)| *l)
        .max();
    top == Some(*layer)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    /// A fresh folder holding `csv` as its `manifest.csv`; the caller removes it.
    fn manifest_dir(tag: &str, csv: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("tactus-lofo-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("manifest.csv"), csv).unwrap();
        dir
    }

    /// Of a layered object only its hardest layer is fitted, whatever the rows' order; a
    /// recording without layers, or unknown to the manifests, always.
    #[test]
    fn only_an_objects_hardest_layer_is_fitted() {
        let dir = manifest_dir(
            "layers",
            "file,object_id,layer_index\n\
             a.wav,ride,0\n\
             b.wav,ride,2\n\
             c.wav,ride,1\n\
             d.wav,bell,0\n\
             e.wav,,\n",
        );
        let mut prov = BTreeMap::new();
        for (file, p) in read_provenance(&dir).unwrap() {
            prov.insert(provenance_key(&dir.join(file)), p);
        }
        let fitted: Vec<bool> = ["a", "b", "c", "d", "e", "f"]
            .iter()
            .map(|n| fitted_layer(&dir.join(format!("{n}.wav")), &prov))
            .collect();
        assert_eq!(fitted, [false, true, false, true, true, true]);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A manifest's kit wins over the name; a name of four `_` fields or more gives its third;
    /// any other name is its own kit.
    #[test]
    fn a_recordings_kit_comes_from_the_manifest_else_its_name() {
        let prov = Provenance {
            kit: Some("Forzee-Stereo".into()),
            ..Provenance::default()
        };
        assert_eq!(
            kit_of("metal_ride-cymbal_x_ride-1.wav", Some(&prov)),
            "forzee stereo"
        );
        assert_eq!(
            kit_of("metal_ride-cymbal_bja-pacific_ride-1.wav", None),
            "bja pacific"
        );
        assert_eq!(
            kit_of(
                "metal_ride-cymbal_bja-pacific_ride-1.wav",
                Some(&Provenance::default())
            ),
            "bja pacific"
        );
        assert_eq!(
            kit_of("metal_ride-cymbal_take1.wav", None),
            "metal_ride-cymbal_take1"
        );
        assert_eq!(kit_of("hit.wav", None), "hit");
    }

    /// Both manifests' wordings of a fade, a loud cut and a gain copy, and a kit.
    #[test]
    fn provenance_reads_fades_cuts_and_copies() {
        let dir = manifest_dir(
            "prov",
            "file,end_condition,end_level_db_re_peak,same_recording_as,kit\n\
             a.wav,editor fade-out from ~1.4 s (natural decay reached -63 dB re peak before it),,\n\
             b.wav,sample ends while still decaying (last level -35 dB re peak),,\n\
             c.wav,sample ends while still decaying (last level -58 dB re peak),,\n\
             d.wav,ends while still decaying,-20.5,\n\
             e.wav,fade found,,\n\
             f.wav,decays to noise floor,-70,e.wav,Forzee Stereo\n",
        );
        let p = read_provenance(&dir).unwrap();
        let edited: Vec<bool> = ["a", "b", "c", "d", "e", "f"]
            .iter()
            .map(|n| p[&format!("{n}.wav")].edited)
            .collect();
        assert_eq!(edited, [true, true, false, true, true, false]);
        let censored: Vec<Option<bool>> = ["a", "b", "c", "d", "e", "f"]
            .iter()
            .map(|n| p[&format!("{n}.wav")].censored)
            .collect();
        // A fade after the decay reached -60 dB leaves it measured; a cut at -58 dB does not.
        let (t, f) = (Some(true), Some(false));
        assert_eq!(censored, [f, t, t, t, t, f]);
        assert_eq!(p["f.wav"].same_recording_as.as_deref(), Some("e.wav"));
        assert_eq!(p["f.wav"].kit.as_deref(), Some("Forzee Stereo"));
        assert_eq!(p["a.wav"].kit, None);
        std::fs::remove_dir_all(&dir).ok();
    }
}
