//! `tactus eval --leave-family-out MATERIAL` and `--leave-kit-out FAMILY` (docs/evaluation.md,
//! "Leave one family out"): does a material generalise to object families it was not fitted
//! from, and a family to objects of other kits? For each family of the material (each kit of the
//! family), the material (family) is fitted from the recordings of all *other* families (kits)
//! and its draws are judged against the held-out group's recordings:
//!
//! - **recognition**: draws classified as the material by the classifier trained on every
//!   recording (all materials), beside how many of the held-out family's own recordings that
//!   classifier recognises (a family the classifier cannot place is no test of the draws);
//! - **feature ranges**: each feature's draw median against the held-out family's 10–90 %
//!   range, from at least [`MIN_RANGE_RECORDINGS`] distinct recordings (gain copies count
//!   once); the decay features (tan φ, T60, slope, EDT) leave out recordings whose manifest
//!   marks an editor fade or a truncation, since those end before the decay does;
//! - **discriminator**: a nearest-class-mean classifier trained to tell the family's recordings
//!   from as many draws, scored by leave-one-out accuracy beside the majority baseline. Draws
//!   that sound like new objects of the family leave it at chance; judged, as the ranges, from
//!   at least [`MIN_RANGE_RECORDINGS`] distinct recordings;
//! - **velocity**: for the family's objects with velocity layers, the hardest/softest-layer
//!   centroid ratio of the recordings against the draws' at the speeds the plugin plays those
//!   layers at ([`crate::fit::velocity`]).
//!
//! The folds are fitted as `presets/refit.sh` fits the shipped presets: of a layered object
//! only its hardest layer ([`fitted_layer`]). Every such recording is fitted once; each
//! held-out group's preset pools the other groups' fits, so the cost is one `tactus fit` of the
//! material (family) plus the draws. The held-out group is judged on all its recordings, every
//! layer, as `tactus eval` judges the shipped presets.

use crate::eval::classifier::{nearest_families, nearest_families_line, Classifier, NearestFamily};
use crate::eval::draws::{render_draw, seconds_like, RENDER_FS};
use crate::eval::features::{self, measure_recordings, Measured, SoundFeatures, FEATURE_NAMES, N_FEATURES};
use crate::eval::labels::{label_folder, Labelled, Skipped};
use crate::eval::report::FeatureCheck;
use crate::eval::RANGE_PERCENTILES;
use crate::fit::cli::{pool, Pooling};
use crate::fit::family::FamilyBy;
use crate::fit::pipeline::FileResult;
use crate::fit::velocity;
use crate::stats::quantile;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Fewest distinct recordings a family's 10–90 % range is taken from; below it the range
/// checks report SKIPPED with the count.
pub const MIN_RANGE_RECORDINGS: usize = 3;
/// Features read off the decay, whose ranges leave out faded or truncated recordings.
pub const DECAY_FEATURES: [&str; 4] = ["tan_phi", "t60_s", "decay_slope", "edt_s"];
/// A draw ratio within this factor of the recordings' counts as matching (±25 %).
pub const VELOCITY_TOLERANCE: f64 = 0.25;
/// A recording that ends still ringing louder than this (dB re its peak) is truncated.
const TRUNCATED_ABOVE_DB: f64 = -40.0;
/// Draws per exponent for the velocity ratio (as the fit's).
const VELOCITY_DRAWS: u64 = 8;

/// How a manifest says a recording was edited, and which recording it is a gain copy of.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Provenance {
    /// Ends in an editor fade or is cut while still loud: its decay is not the object's.
    pub edited: bool,
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
    let path = dir.join("manifest.csv");
    let mut out = BTreeMap::new();
    if !path.is_file() {
        return Ok(out);
    }
    let mut rd = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(&path)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let headers = rd
        .headers()
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
        .clone();
    let col = |n: &str| headers.iter().position(|h| h.trim().eq_ignore_ascii_case(n));
    let (c_file, c_end, c_level, c_same, c_kit) = (
        col("file"),
        col("end_condition"),
        col("end_level_db_re_peak"),
        col("same_recording_as"),
        col("kit"),
    );
    let (c_object, c_layer) = (col("object_id"), col("layer_index"));
    let Some(c_file) = c_file else {
        return Ok(out);
    };
    for row in rd.records() {
        let row = row.map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let get = |c: Option<usize>| c.and_then(|c| row.get(c)).unwrap_or("").trim().to_owned();
        let end = get(c_end).to_lowercase();
        let level = get(c_level).parse::<f64>().ok().or_else(|| {
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
        let (same, kit, object) = (get(c_same), get(c_kit), get(c_object));
        let layer = get(c_layer).parse::<i64>().ok();
        out.insert(
            get(Some(c_file)),
            Provenance {
                edited,
                same_recording_as: (!same.is_empty()).then_some(same),
                kit: (!kit.is_empty()).then_some(kit),
                layer: layer.filter(|_| !object.is_empty()).map(|l| (object, l)),
            },
        );
    }
    Ok(out)
}

/// The key of the recording at `path` in a map of provenances gathered from several folders.
fn provenance_key(path: &Path) -> String {
    path.display().to_string()
}

/// The provenance of the recording at `path`, if a manifest lists it.
fn provenance<'a>(prov: &'a BTreeMap<String, Provenance>, path: &Path) -> Option<&'a Provenance> {
    prov.get(&provenance_key(path))
}

/// Leave-one-out accuracy of a classifier telling recordings from draws.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Discriminator {
    /// Recordings of the held-out family.
    pub recordings: usize,
    /// Draws (as many as recordings, where there are enough).
    pub draws: usize,
    /// Share classified correctly, each sample by a classifier trained on all the others.
    pub accuracy: f64,
    /// Share of the larger class: what always guessing it scores.
    pub baseline: f64,
}

/// Nearest-class-mean leave-one-out accuracy of telling `a` from `b`.
pub fn discriminate(a: &[[f64; N_FEATURES]], b: &[[f64; N_FEATURES]]) -> Option<Discriminator> {
    let all: Vec<(usize, [f64; N_FEATURES])> = a
        .iter()
        .map(|v| (0, *v))
        .chain(b.iter().map(|v| (1, *v)))
        .collect();
    if a.len() < 2 || b.len() < 2 {
        return None;
    }
    let mut correct = 0;
    for i in 0..all.len() {
        let rest: Vec<&(usize, [f64; N_FEATURES])> = all
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, s)| s)
            .collect();
        let n = rest.len() as f64;
        let mean: [f64; N_FEATURES] = std::array::from_fn(|j| rest.iter().map(|s| s.1[j]).sum::<f64>() / n);
        let sd: [f64; N_FEATURES] = std::array::from_fn(|j| {
            let v = rest.iter().map(|s| (s.1[j] - mean[j]).powi(2)).sum::<f64>() / (n - 1.0);
            if v > 0.0 {
                v.sqrt()
            } else {
                1.0
            }
        });
        let z = |v: &[f64; N_FEATURES]| -> [f64; N_FEATURES] {
            std::array::from_fn(|j| (v[j] - mean[j]) / sd[j])
        };
        let centre = |class: usize| -> [f64; N_FEATURES] {
            let zs: Vec<[f64; N_FEATURES]> = rest.iter().filter(|s| s.0 == class).map(|s| z(&s.1)).collect();
            std::array::from_fn(|j| zs.iter().map(|v| v[j]).sum::<f64>() / zs.len() as f64)
        };
        let (c0, c1, zi) = (centre(0), centre(1), z(&all[i].1));
        let d = |c: &[f64; N_FEATURES]| (0..N_FEATURES).map(|j| (zi[j] - c[j]).powi(2)).sum::<f64>();
        let predicted = usize::from(d(&c1) < d(&c0));
        correct += usize::from(predicted == all[i].0);
    }
    Some(Discriminator {
        recordings: a.len(),
        draws: b.len(),
        accuracy: correct as f64 / all.len() as f64,
        baseline: a.len().max(b.len()) as f64 / all.len() as f64,
    })
}

/// The recordings' and the draws' hardest/softest centroid ratio for a family's layered objects.
#[derive(Debug, Clone, Serialize)]
pub struct VelocityCheck {
    /// Objects with at least two layers.
    pub objects: usize,
    /// Median of the recorded objects' ratios.
    pub recorded_ratio: f64,
    /// Median over draws at the objects' median soft and hard speeds.
    pub drawn_ratio: f64,
    /// Drawn within ±[`VELOCITY_TOLERANCE`] of recorded.
    pub within: bool,
}

/// What each fold of a leave-one-out evaluation holds out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum HoldOut {
    /// Each family of a material, the material fitted from the other families.
    Family,
    /// Each kit (drum kit, sound bank) of a family, the family fitted from the other kits: the
    /// family preset met on an object it has never heard, recorded through another chain.
    Kit,
}

impl HoldOut {
    /// The group's name in reports, singular.
    pub fn word(self) -> &'static str {
        match self {
            HoldOut::Family => "family",
            HoldOut::Kit => "kit",
        }
    }

    /// What is fitted from the groups: a material's families, a family's kits.
    pub fn subject(self) -> &'static str {
        match self {
            HoldOut::Family => "material",
            HoldOut::Kit => "family",
        }
    }

    /// Plural of [`HoldOut::word`].
    pub fn words(self) -> &'static str {
        match self {
            HoldOut::Family => "families",
            HoldOut::Kit => "kits",
        }
    }
}

/// The kit of a recording: the manifest's `kit`, else the third `_` field of a name
/// `<material>_<family>_<kit>_….wav` (the recordings folders' naming), else the file itself.
pub fn kit_of(name: &str, prov: Option<&Provenance>) -> String {
    if let Some(k) = prov.and_then(|p| p.kit.as_deref()) {
        return crate::eval::labels::normalise_label(k);
    }
    let stem = name.strip_suffix(".wav").unwrap_or(name);
    match stem.split('_').nth(2) {
        Some(k) if stem.split('_').count() > 3 => crate::eval::labels::normalise_label(k),
        _ => stem.to_owned(),
    }
}

/// Whether the recording at `path` is fitted: a velocity layer of a layered object only when it
/// is that object's hardest (highest `layer_index` in its folder's manifest), as
/// `presets/refit.sh` fits the shipped presets from the strike nearest the default hit that
/// fitted levels are compensated for; a recording without layers always. The contact exponent
/// still learns from every layer ([`crate::fit::velocity`]).
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

/// One fold: a held-out family or kit.
#[derive(Debug, Clone, Serialize)]
pub struct HeldOutGroup {
    /// The family or kit held out.
    pub held_out: String,
    /// Its recordings measured (distinct recordings: gain copies once).
    pub recordings: usize,
    /// Families (kits) the preset was fitted from for it.
    pub fitted_from: Vec<String>,
    /// Recordings the preset pooled.
    pub fitted_recordings: usize,
    /// The fitted contact exponent.
    pub contact_exponent: f64,
    /// The held-out family's recordings the all-recordings classifier recognises / judged.
    pub recordings_recognised: (usize, usize),
    /// Draws rendered.
    pub draws: usize,
    /// Draws recognised as the material.
    pub recognised: usize,
    /// The family centres the draws fell nearest, most draws first.
    pub nearest_families: Vec<NearestFamily>,
    /// Per feature against the family's range; `None` where the family has too few usable
    /// recordings (see `range_skipped`).
    pub features: Vec<Option<FeatureCheck>>,
    /// Per feature, why its range was not judged.
    pub range_skipped: Vec<Option<String>>,
    /// Recordings against as many draws; `None` with fewer than [`MIN_RANGE_RECORDINGS`]
    /// distinct recordings.
    pub discriminator: Option<Discriminator>,
    /// Velocity layers, where the family has layered objects.
    pub velocity: Option<VelocityCheck>,
}

impl HeldOutGroup {
    /// Whether the all-recordings classifier recognises the group's recordings (a majority).
    pub fn classifier_knows_group(&self) -> bool {
        2 * self.recordings_recognised.0 > self.recordings_recognised.1
    }

    /// The check of `feature`, when judged.
    pub fn check(&self, feature: &str) -> Option<&FeatureCheck> {
        let j = FEATURE_NAMES.iter().position(|f| *f == feature)?;
        self.features[j].as_ref()
    }
}

/// The whole leave-one-out evaluation of one material (family).
#[derive(Debug, Clone, Serialize)]
pub struct LofoReport {
    /// What each fold holds out.
    pub held_out: HoldOut,
    /// The material (with [`HoldOut::Family`]) or family (with [`HoldOut::Kit`]) fitted.
    pub fitted: String,
    /// Its material class.
    pub material: String,
    /// Recording folders.
    pub folders: Vec<String>,
    /// Recordings measured (all materials).
    pub recordings: usize,
    /// Recordings of the material (family) fitted.
    pub fitted_recordings: usize,
    /// The material was fitted with dense mode fields (`--dense`).
    pub dense: bool,
    /// Recordings left out, with reasons (unlabelled, unreadable, unfittable).
    pub skipped: Vec<Skipped>,
    /// Per held-out family (kit), in name order.
    pub groups: Vec<HeldOutGroup>,
}

/// Labels and measures the recordings of every folder in `dirs`.
fn measure_folders(
    dirs: &[PathBuf],
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<(Vec<Measured>, Vec<Skipped>, BTreeMap<String, Provenance>)> {
    let (mut labels, mut skipped): (Vec<Labelled>, Vec<Skipped>) = (Vec::new(), Vec::new());
    let mut prov = BTreeMap::new();
    for d in dirs {
        let (l, s) = label_folder(d)?;
        for (file, p) in read_provenance(d)? {
            prov.insert(provenance_key(&d.join(file)), p);
        }
        labels.extend(l);
        skipped.extend(s);
    }
    let (recs, bad) = measure_recordings(&labels, &|| progress("recording"));
    skipped.extend(bad);
    Ok((recs, skipped, prov))
}

/// Runs the leave-one-out evaluation of `of` (a material with [`HoldOut::Family`], a family
/// with [`HoldOut::Kit`]) on the recordings of `dirs`, with `draws` draws per held-out group,
/// fitted with dense mode fields when `dense` (`tactus fit --dense`). `progress(what)` ticks
/// once per recording measured, per recording fitted and per draw.
pub fn leave_one_out(
    dirs: &[PathBuf],
    held_out: HoldOut,
    of: &str,
    draws: usize,
    count: usize,
    dense: bool,
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<LofoReport> {
    let of = crate::eval::labels::normalise_label(of);
    let (recs, mut skipped, prov) = measure_folders(dirs, progress)?;
    let classifier = Classifier::train(
        recs.iter()
            .map(|r| (r.label.material.as_str(), r.label.family.as_str(), &r.features)),
    )
    .ok_or_else(|| {
        anyhow::anyhow!("the recordings hold fewer than two material classes; nothing to discriminate")
    })?;
    // The recordings of the material (family), each with the family (kit) it belongs to.
    let mine: Vec<(String, &Measured)> =
        recs.iter()
            .filter_map(|r| match held_out {
                HoldOut::Family => (r.label.material == of).then(|| (r.label.family.clone(), r)),
                HoldOut::Kit => (r.label.family == of)
                    .then(|| (kit_of(&r.label.name, provenance(&prov, &r.label.path)), r)),
            })
            .collect();
    if mine.is_empty() {
        anyhow::bail!(
            "{} '{of}': no recordings of it among the folders",
            held_out.subject()
        );
    }
    let materials: BTreeSet<&str> = mine.iter().map(|(_, r)| r.label.material.as_str()).collect();
    let material = match (held_out, materials.len()) {
        (HoldOut::Family, _) => of.clone(),
        (HoldOut::Kit, 1) => materials.first().map(|m| (*m).to_owned()).unwrap_or_default(),
        (HoldOut::Kit, _) => anyhow::bail!(
            "family '{of}': its recordings are labelled with {} materials ({}); a family fits one",
            materials.len(),
            materials.iter().copied().collect::<Vec<_>>().join(", ")
        ),
    };
    let groups: BTreeSet<&String> = mine.iter().map(|(g, _)| g).collect();
    if groups.len() < 2 {
        anyhow::bail!(
            "{} '{of}': {} {} among the recordings ({}); leaving one out needs at least two",
            held_out.subject(),
            groups.len(),
            if groups.len() == 1 {
                held_out.word()
            } else {
                held_out.words()
            },
            groups.iter().map(|g| g.as_str()).collect::<Vec<_>>().join(", ")
        );
    }
    // Fit every fitted recording once.
    let to_fit: Vec<&(String, &Measured)> = mine
        .iter()
        .filter(|(_, r)| fitted_layer(&r.label.path, &prov))
        .collect();
    let fits: Vec<(String, Result<FileResult, String>)> = to_fit
        .par_iter()
        .map(|(g, r)| {
            let f = std::panic::catch_unwind(|| crate::fit::pipeline::fit_file(&r.label.path))
                .unwrap_or_else(|_| Err(anyhow::anyhow!("internal error while fitting")))
                .map_err(|e| format!("{e:#}").replace(&format!("{}: ", r.label.path.display()), ""));
            progress("fit");
            (g.clone(), f)
        })
        .collect();
    let mut fitted: Vec<(String, FileResult)> = Vec::new();
    for ((g, f), (_, r)) in fits.into_iter().zip(&to_fit) {
        match f {
            Ok(f) => fitted.push((g, f)),
            Err(reason) => skipped.push(Skipped {
                name: r.label.name.clone(),
                reason: format!("cannot be fitted: {reason}"),
            }),
        }
    }
    let mut out = Vec::new();
    for &g in &groups {
        let rest: Vec<FileResult> = fitted
            .iter()
            .filter(|(f, _)| f != g)
            .map(|(_, r)| r.clone())
            .collect();
        let fitted_from: Vec<String> = fitted
            .iter()
            .filter(|(f, _)| f != g)
            .map(|(f, _)| f.clone())
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        if rest.is_empty() {
            continue;
        }
        let name = format!("{of} without {g}");
        let pooling = Pooling {
            material: &material,
            name: Some(&name),
            family_by: FamilyBy::Auto,
            count,
            dense,
        };
        let preset =
            pool(&pooling, &rest, &crate::fit::cli::Silent).map_err(|e| anyhow::anyhow!("{name}: {e:#}"))?;
        let held: Vec<&Measured> = mine.iter().filter(|(h, _)| h == g).map(|(_, r)| *r).collect();
        out.push(judge_group(
            g,
            &held,
            &preset,
            fitted_from,
            rest.len(),
            &classifier,
            &material,
            draws,
            &prov,
            progress,
        )?);
    }
    Ok(LofoReport {
        held_out,
        fitted: of,
        material,
        folders: dirs.iter().map(|d| d.display().to_string()).collect(),
        recordings: recs.len(),
        fitted_recordings: fitted.len(),
        dense,
        skipped,
        groups: out,
    })
}

#[allow(clippy::too_many_arguments)]
fn judge_group(
    group: &str,
    held: &[&Measured],
    preset: &crate::preset::Preset,
    fitted_from: Vec<String>,
    fitted_recordings: usize,
    classifier: &Classifier,
    material: &str,
    draws: usize,
    prov: &BTreeMap<String, Provenance>,
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<HeldOutGroup> {
    let prov_of = |m: &Measured| provenance(prov, &m.label.path).cloned().unwrap_or_default();
    let distinct: Vec<&Measured> = held
        .iter()
        .copied()
        .filter(|m| prov_of(m).same_recording_as.is_none())
        .collect();
    let seconds = seconds_like(held.iter().map(|m| m.duration_s));
    let feats: Vec<Option<SoundFeatures>> = (1..=draws as u64)
        .into_par_iter()
        .map(|seed| {
            let f = features::sound_features(&render_draw(preset, seed, seconds), RENDER_FS).ok();
            progress("draw");
            f
        })
        .collect();
    let ok: Vec<&SoundFeatures> = feats.iter().flatten().collect();
    let nearest = nearest_families(ok.iter().filter_map(|f| classifier.nearest(f)));
    let recognised = nearest
        .iter()
        .filter(|n| n.class == material)
        .map(|n| n.draws)
        .sum();
    let recordings_recognised = (
        distinct
            .iter()
            .filter(|m| classifier.classify(&m.features) == material)
            .count(),
        distinct.len(),
    );
    let (lo, hi) = RANGE_PERCENTILES;
    let (mut features, mut range_skipped) = (Vec::new(), Vec::new());
    for (j, name) in FEATURE_NAMES.iter().enumerate() {
        let usable: Vec<f64> = distinct
            .iter()
            .filter(|m| !(DECAY_FEATURES.contains(name) && prov_of(m).edited))
            .map(|m| m.features.values()[j])
            .collect();
        if usable.len() < MIN_RANGE_RECORDINGS {
            features.push(None);
            range_skipped.push(Some(format!(
                "SKIPPED: {} usable recording{} (need {MIN_RANGE_RECORDINGS}{})",
                usable.len(),
                if usable.len() == 1 { "" } else { "s" },
                if DECAY_FEATURES.contains(name) {
                    "; faded or truncated ones left out"
                } else {
                    ""
                }
            )));
            continue;
        }
        let d: Vec<f64> = ok.iter().map(|f| f.values()[j]).collect();
        let (r10, r90) = (quantile(&usable, lo), quantile(&usable, hi));
        let med = quantile(&d, 0.5);
        features.push(Some(FeatureCheck {
            feature: (*name).to_owned(),
            draws_median: med,
            draws_p10: quantile(&d, lo),
            draws_p90: quantile(&d, hi),
            recordings_p10: r10,
            recordings_p90: r90,
            inside: (r10..=r90).contains(&med),
        }));
        range_skipped.push(None);
    }
    let rec_vecs: Vec<[f64; N_FEATURES]> = distinct.iter().map(|m| m.features.vector()).collect();
    let draw_vecs: Vec<[f64; N_FEATURES]> = ok
        .iter()
        .take(rec_vecs.len().max(2))
        .map(|f| f.vector())
        .collect();
    // Fewer recordings than a range needs leave a leave-one-out score of four samples or so,
    // which passes or fails by chance (two recordings scored 0.00–0.50): not judged.
    let discriminator = if rec_vecs.len() >= MIN_RANGE_RECORDINGS {
        discriminate(&rec_vecs, &draw_vecs)
    } else {
        None
    };
    let paths: Vec<PathBuf> = held.iter().map(|m| m.label.path.clone()).collect();
    let objects = velocity::layered_objects(&paths)?;
    let velocity = if objects.is_empty() {
        None
    } else {
        let mut logs = Vec::new();
        for o in &objects {
            logs.push(velocity::recorded_ratio(o)?.ln());
        }
        let med = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            crate::stats::median(&v)
        };
        let soft = med(objects.iter().map(|o| o.soft_speed_m_per_s).collect());
        let hard = med(objects.iter().map(|o| o.hard_speed_m_per_s).collect());
        let recorded = med(logs).exp();
        let drawn = velocity::draws_log_ratio(preset, soft, hard, VELOCITY_DRAWS).map_or(f64::NAN, f64::exp);
        Some(VelocityCheck {
            objects: objects.len(),
            recorded_ratio: recorded,
            drawn_ratio: drawn,
            within: (drawn / recorded - 1.0).abs() <= VELOCITY_TOLERANCE,
        })
    };
    Ok(HeldOutGroup {
        held_out: group.to_owned(),
        recordings: distinct.len(),
        fitted_from,
        fitted_recordings,
        contact_exponent: preset.contact_exponent,
        recordings_recognised,
        draws,
        recognised,
        nearest_families: nearest,
        features,
        range_skipped,
        discriminator,
        velocity,
    })
}

/// The targets' verdicts over a report (docs/evaluation.md, "Leave one family out").
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Summary {
    /// Held-out groups whose recordings the classifier recognises / groups.
    pub known: (usize, usize),
    /// Of those, groups whose draws are recognised ≥ 80 %.
    pub recognised: usize,
    /// Groups with attack share, T60 and EDT judged / with all three inside.
    pub ranged: (usize, usize),
    /// Groups whose discriminator accuracy ≤ baseline + 15 points / with a discriminator.
    pub indistinct: (usize, usize),
    /// Groups with velocity within ±25 % / with layered objects.
    pub velocity: (usize, usize),
}

/// Counts the verdicts of `r`.
pub fn summarise(r: &LofoReport) -> Summary {
    let known: Vec<&HeldOutGroup> = r.groups.iter().filter(|f| f.classifier_knows_group()).collect();
    let rec = known
        .iter()
        .filter(|f| f.recognised as f64 >= 0.8 * f.draws as f64)
        .count();
    let ranged: Vec<&HeldOutGroup> = r
        .groups
        .iter()
        .filter(|f| {
            ["attack_share", "t60_s", "edt_s"]
                .iter()
                .all(|n| f.check(n).is_some())
        })
        .collect();
    let inside = ranged
        .iter()
        .filter(|f| {
            ["attack_share", "t60_s", "edt_s"]
                .iter()
                .all(|n| f.check(n).is_some_and(|c| c.inside))
        })
        .count();
    let disc: Vec<&Discriminator> = r.groups.iter().filter_map(|f| f.discriminator.as_ref()).collect();
    let vel: Vec<&VelocityCheck> = r.groups.iter().filter_map(|f| f.velocity.as_ref()).collect();
    Summary {
        known: (known.len(), r.groups.len()),
        recognised: rec,
        ranged: (ranged.len(), inside),
        indistinct: (
            disc.iter().filter(|d| d.accuracy <= d.baseline + 0.15).count(),
            disc.len(),
        ),
        velocity: (vel.iter().filter(|v| v.within).count(), vel.len()),
    }
}

fn fmt(v: f64) -> String {
    if !v.is_finite() {
        "-".into()
    } else if v != 0.0 && v.abs() < 0.01 {
        format!("{v:.2e}")
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

/// Writes the human-readable report.
pub fn write_table(out: &mut dyn std::io::Write, r: &LofoReport) -> std::io::Result<()> {
    let (word, words) = (r.held_out.word(), r.held_out.words());
    writeln!(
        out,
        "leave one {word} out: {} ({} recordings measured in {}, {} of the {} fitted{})",
        r.fitted,
        r.recordings,
        r.folders.join(", "),
        r.fitted_recordings,
        r.held_out.subject(),
        if r.dense { ", with dense mode fields" } else { "" }
    )?;
    for s in &r.skipped {
        writeln!(out, "  left out {}: {}", s.name, s.reason)?;
    }
    writeln!(
        out,
        "\n{:<24} {:>4} {:>9} {:>7} {:>9} {:>14} {:>14} {:>14} {:>16} {:>13}",
        format!("held-out {word}"),
        "recs",
        "rec known",
        "alpha",
        "draws rec",
        "attack share",
        "t60 s",
        "edt s",
        "discrim (base)",
        "vel rec/draws"
    )?;
    for f in &r.groups {
        let cell = |n: &str| -> String {
            let j = FEATURE_NAMES.iter().position(|x| *x == n).unwrap_or(0);
            match (&f.features[j], &f.range_skipped[j]) {
                (Some(c), _) => format!("{}{}", fmt(c.draws_median), if c.inside { "" } else { "*" }),
                (None, _) => "SKIPPED".into(),
            }
        };
        writeln!(
            out,
            "{:<24} {:>4} {:>9} {:>7.3} {:>9} {:>14} {:>14} {:>14} {:>16} {:>13}",
            f.held_out,
            f.recordings,
            format!("{}/{}", f.recordings_recognised.0, f.recordings_recognised.1),
            f.contact_exponent,
            format!("{}/{}", f.recognised, f.draws),
            cell("attack_share"),
            cell("t60_s"),
            cell("edt_s"),
            f.discriminator.map_or_else(
                || {
                    if f.recordings < MIN_RANGE_RECORDINGS {
                        "SKIPPED".into()
                    } else {
                        "-".into()
                    }
                },
                |d| format!("{:.2} ({:.2})", d.accuracy, d.baseline)
            ),
            f.velocity.as_ref().map_or("-".into(), |v| format!(
                "{:.2}/{:.2}{}",
                v.recorded_ratio,
                v.drawn_ratio,
                if v.within { "" } else { "*" }
            )),
        )?;
    }
    writeln!(
        out,
        "(* = outside the held-out {word}'s 10-90 % range, or velocity ratio off by more than 25 %)"
    )?;
    writeln!(
        out,
        "\nper feature, draws' median [held-out {word}'s 10-90 % range]:"
    )?;
    for f in &r.groups {
        write!(out, "  {}:", f.held_out)?;
        for (j, name) in FEATURE_NAMES.iter().enumerate() {
            match (&f.features[j], &f.range_skipped[j]) {
                (Some(c), _) => write!(
                    out,
                    " {name} {} [{}..{}]{}",
                    fmt(c.draws_median),
                    fmt(c.recordings_p10),
                    fmt(c.recordings_p90),
                    if c.inside { "" } else { "*" }
                )?,
                (None, Some(why)) => write!(out, " {name} {why}")?,
                (None, None) => {}
            }
        }
        writeln!(out)?;
    }
    writeln!(out, "\ndraws nearest the family centres of:")?;
    for f in &r.groups {
        writeln!(
            out,
            "  {}: {}",
            f.held_out,
            nearest_families_line(&f.nearest_families)
        )?;
    }
    let s = summarise(r);
    writeln!(
        out,
        "\nsummary: {}/{} {words} recognised by the classifier themselves; of those, {} with >= 80 % of draws recognised",
        s.known.0, s.known.1, s.recognised
    )?;
    writeln!(
        out,
        "attack share, T60 and EDT all inside the range: {}/{} {words} judged",
        s.ranged.1, s.ranged.0
    )?;
    writeln!(
        out,
        "discriminator at most baseline + 15 points: {}/{} {words}; velocity ratio within 25 %: {}/{} {words}",
        s.indistinct.0, s.indistinct.1, s.velocity.0, s.velocity.1
    )?;
    Ok(())
}

/// `tactus eval --leave-family-out MATERIAL` and `--leave-kit-out FAMILY`.
pub fn run(
    dirs: &[PathBuf],
    held_out: HoldOut,
    of: &str,
    draws: usize,
    dense: bool,
    json: Option<&Path>,
) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    if draws < 2 {
        anyhow::bail!("--draws must be at least 2 for --leave-{}-out", held_out.word());
    }
    if let Some(p) = json {
        std::fs::File::create(p).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", p.display()))?;
    }
    let bar = indicatif::ProgressBar::new_spinner();
    let terminal = std::io::stderr().is_terminal();
    if terminal {
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {pos} measured ({msg}) {elapsed}")
                .expect("valid template"),
        );
    } else {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        eprintln!(
            "leave one {} out: fitting and judging '{of}' on {} folder(s)",
            held_out.word(),
            dirs.len()
        );
    }
    let counts = std::sync::Mutex::new(BTreeMap::<String, usize>::new());
    let started = std::time::Instant::now();
    let report = leave_one_out(
        dirs,
        held_out,
        of,
        draws,
        crate::fit::cli::DEFAULT_COUNT,
        dense,
        &|what| {
            bar.set_message(what.to_owned());
            bar.inc(1);
            // Without a terminal (a log, CI) the spinner is hidden; a line per ten steps of
            // each kind shows a run of half an hour is alive.
            if !terminal {
                let mut c = counts.lock().unwrap_or_else(|e| e.into_inner());
                let n = c.entry(what.to_owned()).or_insert(0);
                *n += 1;
                if n.is_multiple_of(10) {
                    eprintln!("  {what}: {n} done ({:.0} s)", started.elapsed().as_secs_f64());
                }
            }
        },
    )?;
    bar.finish_and_clear();
    crate::eval::emit(
        |out| write_table(out, &report),
        json,
        &(&report, summarise(&report)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh folder holding `csv` as its `manifest.csv`; the caller removes it.
    fn manifest_dir(tag: &str, csv: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("tactus-lofo-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("manifest.csv"), csv).unwrap();
        dir
    }

    fn point(x: f64) -> [f64; N_FEATURES] {
        std::array::from_fn(|j| x + 0.01 * j as f64)
    }

    /// Apart clusters are told apart every time; draws that are the recordings again leave the
    /// discriminator at or below chance.
    #[test]
    fn the_discriminator_separates_only_what_differs() {
        let a: Vec<_> = (0..6).map(|i| point(i as f64 * 0.1)).collect();
        let b: Vec<_> = (0..6).map(|i| point(10.0 + i as f64 * 0.1)).collect();
        let d = discriminate(&a, &b).unwrap();
        assert_eq!((d.accuracy, d.baseline), (1.0, 0.5));
        let d = discriminate(&a, &a.clone()).unwrap();
        assert!(d.accuracy <= 0.5, "{d:?}");
        assert!(discriminate(&a[..1], &b).is_none());
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
        assert_eq!(p["f.wav"].same_recording_as.as_deref(), Some("e.wav"));
        assert_eq!(p["f.wav"].kit.as_deref(), Some("Forzee Stereo"));
        assert_eq!(p["a.wav"].kit, None);
        std::fs::remove_dir_all(&dir).ok();
    }
}
