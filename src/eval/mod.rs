//! `tactus eval`: do a preset's draws sound like the recordings? (docs/evaluation.md)
//!
//! 1. Every recording of a labelled folder ([`labels`]) and every draw of each preset (default
//!    settings, one 1 m/s hit on a new object, seeds `1..=N`, rendered by the real
//!    [`Engine`](crate::engine::Engine), [`draws`]) is measured by the same function,
//!    [`features::sound_features`].
//! 2. A nearest-family-mean classifier on standardised features (z-scores of the training
//!    recordings) is trained on the recordings' families, each under its material class
//!    ([`classifier`]). The recordings' own recognition is measured leaving out the whole
//!    family of each recording (a marimba is judged by a classifier that never heard a
//!    marimba), the draws' recognition with all recordings.
//! 3. Per feature, the draws' median is compared with the recordings' 10–90 % range (of the
//!    preset's family when it was fitted from one family, else of its material class).
//!
//! The results are a [`report::Report`] (printed, and written with `--json`); [`spectrogram`]
//! draws a recording beside three draws (`--spectrograms`). This module is the driver: it reads
//! the fitter's audio and analysis ([`crate::fit`]) and nothing in `fit` reads it.

pub mod classifier;
pub mod components;
pub mod confusion;
pub mod leave_out;
pub mod measured;
pub mod report;
pub mod spectrogram;
pub mod surface_id;

use crate::analysis::features::{measure_recordings, Measured, SoundFeatures, FEATURE_NAMES, N_FEATURES};
use crate::analysis::labels::{label_folder, normalise_label, Labelled, Skipped};
use crate::analysis::render::{render_draw, RENDER_FS};
use crate::preset::Preset;
use crate::work::Observer;
use classifier::{leave_one_family_out, nearest_families, rates, Centre, Classifier};
use rayon::prelude::*;
use report::{FeatureCheck, PresetReport, Reference, Report};
use std::path::{Path, PathBuf};

/// Default number of draws per preset.
pub const DEFAULT_DRAWS: usize = 30;
/// Percentiles of the recordings' range a draw median must lie in.
pub const RANGE_PERCENTILES: (f64, f64) = (0.10, 0.90);

/// The reference of `preset`: a family when the recordings it was fitted from (provenance
/// sources found among the labelled files) are all of one family, or when its name is a family;
/// else its material class.
pub fn reference_of(preset: &Preset, labels: &[Labelled]) -> Reference {
    let families: Vec<&str> = preset
        .provenance
        .sources
        .iter()
        .filter_map(|s| {
            let base = Path::new(s)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())?;
            labels.iter().find(|l| l.name == base).map(|l| l.family.as_str())
        })
        .collect();
    if let Some(first) = families.first() {
        if families.iter().all(|f| f == first) {
            return Reference::Family((*first).to_owned());
        }
        return Reference::Material(normalise_label(&preset.material_class));
    }
    let name = normalise_label(&preset.name);
    if labels.iter().any(|l| l.family == name) {
        return Reference::Family(name);
    }
    Reference::Material(normalise_label(&preset.material_class))
}

/// Renders and judges `draws` draws of `preset` (seeds `1..=draws`, in parallel). The ring
/// times' ranges take the recordings `censored` says end still ringing as lower bounds
/// (docs/evaluation.md, "Censored decays").
pub fn evaluate_preset(
    preset: &Preset,
    draws: usize,
    recs: &[Measured],
    censored: &(dyn Fn(&Measured) -> bool + Sync),
    labels: &[Labelled],
    classifier: &Classifier,
    observer: &dyn Observer,
) -> PresetReport {
    let reference = reference_of(preset, labels);
    let members = reference.members(recs);
    let seconds = crate::analysis::render::seconds_like(members.iter().map(|m| m.duration_s));
    let feats: Vec<Result<SoundFeatures, String>> = (1..=draws as u64)
        .into_par_iter()
        .map(|seed| {
            let f = crate::analysis::features::sound_features(&render_draw(preset, seed, seconds), RENDER_FS);
            observer.advanced("draw", 1);
            f
        })
        .collect();
    let class = normalise_label(&preset.material_class);
    let has_class = classifier.knows(&class);
    // Each measured draw's nearest family centre, once: its class is the prediction.
    let centres: Vec<Option<&Centre>> = feats
        .iter()
        .map(|f| f.as_ref().ok().and_then(|f| classifier.nearest(f)))
        .collect();
    let predicted: Vec<Option<String>> = centres.iter().map(|c| c.map(|c| c.class.clone())).collect();
    let recognised = has_class.then(|| predicted.iter().filter(|p| p.as_deref() == Some(&class)).count());
    let nearest = nearest_families(centres.iter().flatten().copied());
    let ok: Vec<&SoundFeatures> = feats.iter().filter_map(|f| f.as_ref().ok()).collect();
    let features = (0..N_FEATURES)
        .map(|j| {
            let d: Vec<f64> = ok.iter().map(|f| f.values()[j]).collect();
            let r: Vec<f64> = members.iter().map(|m| m.features.values()[j]).collect();
            if leave_out::CENSORED_FEATURES.contains(&FEATURE_NAMES[j]) {
                let c: Vec<bool> = members.iter().map(|m| censored(m)).collect();
                FeatureCheck::of_censored(FEATURE_NAMES[j], &d, &r, &c)
            } else {
                FeatureCheck::of(FEATURE_NAMES[j], &d, &r)
            }
        })
        .collect();
    PresetReport {
        name: preset.name.clone(),
        material_class: class,
        reference,
        reference_count: members.len(),
        draws,
        without_features: feats
            .iter()
            .enumerate()
            .filter_map(|(i, f)| {
                f.as_ref().err().map(|e| Skipped {
                    name: format!("{} seed {}", preset.name, i + 1),
                    reason: e.clone(),
                })
            })
            .collect(),
        recognised,
        predicted,
        nearest_families: nearest,
        draw_features: feats.into_iter().map(Result::ok).collect(),
        features,
    }
}

/// Runs the evaluation of `presets` against the labelled recordings in the folders `dirs`.
/// `observer` hears the count of recordings and draws, then each one measured.
pub fn evaluate(
    dirs: &[PathBuf],
    presets: &[Preset],
    draws: usize,
    observer: &dyn Observer,
) -> anyhow::Result<Report> {
    let (labels, mut skipped) = label_folders(dirs)?;
    observer.started((labels.len() + presets.len() * draws) as u64);
    let (recordings, bad) = measure_recordings(&labels, observer);
    skipped.extend(bad);
    let classifier = Classifier::train(
        recordings
            .iter()
            .map(|r| (r.label.material.as_str(), r.label.family.as_str(), &r.features)),
    )
    .ok_or_else(|| {
        anyhow::anyhow!(
            "{}: the measured recordings hold fewer than two material classes; nothing to discriminate",
            folder_list(dirs)
        )
    })?;
    let prov = leave_out::provenance::read_provenances(dirs)?;
    let censored = |m: &Measured| leave_out::censored(m, &prov);
    let held_out = leave_one_family_out(&recordings);
    let recordings_recognition = rates(&held_out);
    let presets = presets
        .iter()
        .map(|p| evaluate_preset(p, draws, &recordings, &censored, &labels, &classifier, observer))
        .collect();
    Ok(Report {
        recordings_dir: folder_list(dirs),
        recordings,
        skipped,
        held_out,
        recordings_recognition,
        classifier,
        presets,
    })
}

/// The labelled recordings of every folder in `dirs`, in order.
pub fn label_folders(dirs: &[PathBuf]) -> anyhow::Result<(Vec<Labelled>, Vec<Skipped>)> {
    let (mut labels, mut skipped) = (Vec::new(), Vec::new());
    for d in dirs {
        let (l, s) = label_folder(d)?;
        labels.extend(l);
        skipped.extend(s);
    }
    Ok((labels, skipped))
}

fn folder_list(dirs: &[PathBuf]) -> String {
    dirs.iter()
        .map(|d| d.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Resolves `--preset` arguments: a `.json` file or existing path is loaded, anything else is a
/// built-in preset name (or material class). Empty: every built-in fitted preset.
pub fn resolve_presets(args: &[String]) -> anyhow::Result<Vec<Preset>> {
    let builtins = crate::engine::materials::shipped_presets();
    if args.is_empty() {
        return Ok(builtins
            .into_iter()
            .filter(|p| p.origin == crate::preset::Origin::Fitted)
            .collect());
    }
    args.iter()
        .map(|a| {
            let path = Path::new(a);
            if path.exists() || a.to_ascii_lowercase().ends_with(".json") {
                return Preset::load(path).map_err(|e| anyhow::anyhow!("{e}"));
            }
            crate::scene::builtin_material(a).ok_or_else(|| {
                let names: Vec<&str> = builtins.iter().map(|p| p.name.as_str()).collect();
                anyhow::anyhow!(
                    "unknown preset '{a}' (built-in: {}; or a preset .json file)",
                    names.join(", ")
                )
            })
        })
        .collect()
}

/// The member nearest to the members' mean feature vector (standardised by their own spread):
/// a typical recording to show beside the draws.
pub fn representative<'a>(members: &[&'a Measured]) -> Option<&'a Measured> {
    let vs: Vec<[f64; N_FEATURES]> = members.iter().map(|m| m.features.vector()).collect();
    let n = vs.len() as f64;
    let mean: [f64; N_FEATURES] = std::array::from_fn(|j| vs.iter().map(|v| v[j]).sum::<f64>() / n);
    let sd: [f64; N_FEATURES] = std::array::from_fn(|j| {
        let s = (vs.iter().map(|v| (v[j] - mean[j]).powi(2)).sum::<f64>() / n).sqrt();
        if s > 0.0 {
            s
        } else {
            1.0
        }
    });
    let d = |v: &[f64; N_FEATURES]| {
        (0..N_FEATURES)
            .map(|j| ((v[j] - mean[j]) / sd[j]).powi(2))
            .sum::<f64>()
    };
    members
        .iter()
        .zip(&vs)
        .min_by(|a, b| {
            d(a.1)
                .total_cmp(&d(b.1))
                .then_with(|| a.0.label.name.cmp(&b.0.label.name))
        })
        .map(|(m, _)| *m)
}
