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
//!   once); the ring times (T60, EDT) count recordings that end still ringing as lower bounds
//!   (censored: docs/evaluation.md, "Censored decays"), the other decay features (tan φ, slope)
//!   leave out recordings whose manifest marks an editor fade or a truncation. A held-out
//!   group's feature whose range lies wholly beyond the other groups' is not judged (`!`);
//! - **discriminator**: a nearest-class-mean classifier trained to tell the family's recordings
//!   from as many draws, scored by leave-one-out accuracy beside the majority baseline. Draws
//!   that sound like new objects of the family leave it at chance; judged, as the ranges, from
//!   at least [`MIN_RANGE_RECORDINGS`] distinct recordings;
//! - **velocity**: for the family's objects with velocity layers, the hardest/softest-layer
//!   centroid ratio of the recordings against the draws' at the speeds the plugin plays those
//!   layers at ([`crate::fit::pool::velocity`]).
//!
//! The folds are fitted as `presets/refit.sh` fits the shipped presets: of a layered object
//! only its hardest layer ([`fitted_layer`]). Every such recording is fitted once; each
//! held-out group's preset pools the other groups' fits, so the cost is one `tactus fit` of the
//! material (family) plus the draws. The held-out group is judged on all its recordings, every
//! layer, as `tactus eval` judges the shipped presets.

pub mod judge;
pub mod provenance;
pub mod table;

use crate::analysis::features::{measure_recordings, Measured, FEATURE_NAMES};
use crate::analysis::labels::{label_folder, normalise_label, Labelled, Skipped};
use crate::eval::classifier::{Classifier, NearestFamily};
use crate::eval::report::FeatureCheck;
use crate::fit::pool::Pooling;
use crate::fit::recording::FileResult;
use crate::fit::run::fit_file_guarded;
use crate::work::{Observer, Silent};
use judge::{judge_group, others_ranges, Discriminator, VelocityCheck};
use provenance::{fitted_layer, kit_of, provenance, read_provenances, Provenance};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

pub use judge::{censored, CENSORED_FEATURES, DECAY_FEATURES, MIN_RANGE_RECORDINGS, VELOCITY_TOLERANCE};

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
    /// Per feature, the 10–90 % range of the other groups' recordings, every layer (what the
    /// fold was fitted from); `None` from fewer than [`MIN_RANGE_RECORDINGS`].
    pub others_ranges: Vec<Option<(f64, f64)>>,
    /// Per feature, how many of the other groups' recordings its range counts as censored
    /// (ring times that are lower bounds: [`judge::CENSORED_FEATURES`]).
    pub others_censored: Vec<usize>,
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

    /// Whether the group's 10–90 % range of `feature` (judged) lies wholly outside the other
    /// groups' ([`others_ranges`](Self::others_ranges)): a median inside it would be a sound
    /// none of the fold's recordings has.
    pub fn beyond_others(&self, feature: &str) -> bool {
        let Some(j) = FEATURE_NAMES.iter().position(|f| *f == feature) else {
            return false;
        };
        match (&self.features[j], self.others_ranges.get(j).copied().flatten()) {
            (Some(c), Some((lo, hi))) => c.recordings_p90 < lo || c.recordings_p10 > hi,
            _ => false,
        }
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
    observer: &dyn Observer,
) -> anyhow::Result<(Vec<Measured>, Vec<Skipped>, BTreeMap<String, Provenance>)> {
    let (mut labels, mut skipped): (Vec<Labelled>, Vec<Skipped>) = (Vec::new(), Vec::new());
    for d in dirs {
        let (l, s) = label_folder(d)?;
        labels.extend(l);
        skipped.extend(s);
    }
    let prov = read_provenances(dirs)?;
    let (recs, bad) = measure_recordings(&labels, observer);
    skipped.extend(bad);
    Ok((recs, skipped, prov))
}

/// The recordings of the subject `of` (a material's, or a family's), each with the group (family
/// or kit) it belongs to; the subject's material class; its groups. Errors when there is
/// nothing to leave out.
fn subject<'a>(
    recs: &'a [Measured],
    held_out: HoldOut,
    of: &str,
    prov: &BTreeMap<String, Provenance>,
) -> anyhow::Result<(Vec<(String, &'a Measured)>, String)> {
    let mine: Vec<(String, &Measured)> =
        recs.iter()
            .filter_map(|r| match held_out {
                HoldOut::Family => (r.label.material == of).then(|| (r.label.family.clone(), r)),
                HoldOut::Kit => (r.label.family == of)
                    .then(|| (kit_of(&r.label.name, provenance(prov, &r.label.path)), r)),
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
        (HoldOut::Family, _) => of.to_owned(),
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
    Ok((mine, material))
}

/// Fits every recording of `mine` that a preset would be fitted from ([`fitted_layer`]) once,
/// in parallel, each with its group (with what dense mode fields need when `dense`); the ones
/// that cannot be fitted go to `skipped`.
fn fit_once(
    mine: &[(String, &Measured)],
    prov: &BTreeMap<String, Provenance>,
    dense: bool,
    observer: &dyn Observer,
    skipped: &mut Vec<Skipped>,
) -> Vec<(String, FileResult)> {
    let to_fit: Vec<&(String, &Measured)> = mine
        .iter()
        .filter(|(_, r)| fitted_layer(&r.label.path, prov))
        .collect();
    let fits: Vec<anyhow::Result<FileResult>> = to_fit
        .par_iter()
        .map(|(_, r)| {
            let f = fit_file_guarded(&r.label.path, dense);
            observer.advanced("fit", 1);
            f
        })
        .collect();
    let mut fitted = Vec::new();
    for (f, (g, r)) in fits.into_iter().zip(to_fit) {
        match f {
            Ok(f) => fitted.push((g.clone(), f)),
            Err(e) => skipped.push(Skipped {
                name: r.label.name.clone(),
                reason: format!(
                    "cannot be fitted: {}",
                    format!("{e:#}").replace(&format!("{}: ", r.label.path.display()), "")
                ),
            }),
        }
    }
    fitted
}

/// Runs the leave-one-out evaluation of `of` (a material with [`HoldOut::Family`], a family
/// with [`HoldOut::Kit`]) on the recordings of `dirs`, with `draws` draws per held-out group,
/// fitted as `tactus fit` fits (with dense mode fields when `dense`, `tactus fit --dense`).
/// `observer` hears each recording measured, each recording fitted and each draw.
pub fn leave_one_out(
    dirs: &[PathBuf],
    held_out: HoldOut,
    of: &str,
    draws: usize,
    dense: bool,
    observer: &dyn Observer,
) -> anyhow::Result<LofoReport> {
    let of = normalise_label(of);
    let (recs, mut skipped, prov) = measure_folders(dirs, observer)?;
    let classifier = Classifier::train(
        recs.iter()
            .map(|r| (r.label.material.as_str(), r.label.family.as_str(), &r.features)),
    )
    .ok_or_else(|| {
        anyhow::anyhow!("the recordings hold fewer than two material classes; nothing to discriminate")
    })?;
    let (mine, material) = subject(&recs, held_out, &of, &prov)?;
    let groups: BTreeSet<&String> = mine.iter().map(|(g, _)| g).collect();
    let fitted = fit_once(&mine, &prov, dense, observer, &mut skipped);
    let mut out = Vec::new();
    for &g in &groups {
        let rest: Vec<FileResult> = fitted
            .iter()
            .filter(|(f, _)| f != g)
            .map(|(_, r)| r.clone())
            .collect();
        if rest.is_empty() {
            continue;
        }
        let fitted_from: Vec<String> = fitted
            .iter()
            .filter(|(f, _)| f != g)
            .map(|(f, _)| f.clone())
            .collect::<BTreeSet<_>>()
            .into_iter()
            .collect();
        let name = format!("{of} without {g}");
        let preset = Pooling::new(&material)
            .named(&name)
            .dense(dense)
            .preset(&rest, &Silent)
            .map_err(|e| anyhow::anyhow!("{name}: {e:#}"))?;
        let held: Vec<&Measured> = mine.iter().filter(|(h, _)| h == g).map(|(_, r)| *r).collect();
        let others: Vec<&Measured> = mine.iter().filter(|(h, _)| h != g).map(|(_, r)| *r).collect();
        let mut group = judge_group(g, &held, &preset, &classifier, draws, &prov, observer)?;
        (group.others_ranges, group.others_censored) = others_ranges(&others, &prov);
        group.fitted_from = fitted_from;
        group.fitted_recordings = rest.len();
        out.push(group);
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
