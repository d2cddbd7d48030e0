//! Judging one held-out group: the fold's draws against the group's recordings — recognition,
//! feature ranges, a real-vs-synthetic discriminator, velocity layers.

use super::provenance::{provenance, Provenance};
use super::HeldOutGroup;
use crate::analysis::features::{self, Measured, SoundFeatures, FEATURE_NAMES, N_FEATURES};
use crate::analysis::render::{render_draw, seconds_like, RENDER_FS};
use crate::eval::classifier::{nearest_families, Classifier};
use crate::eval::report::FeatureCheck;
use crate::fit::pool::velocity;
use crate::preset::Preset;
use crate::work::Observer;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Fewest distinct recordings a family's 10–90 % range is taken from; below it the range
/// checks report SKIPPED with the count.
pub const MIN_RANGE_RECORDINGS: usize = 3;
/// Features read off the decay. Their ranges leave out faded or truncated recordings, except
/// the ring times ([`CENSORED_FEATURES`]).
pub const DECAY_FEATURES: [&str; 4] = ["tan_phi", "t60_s", "decay_slope", "edt_s"];
/// Ring times, whose ranges keep every recording and count the censored ones (those that end
/// still ringing: [`crate::analysis::censoring`]) as lower bounds
/// ([`crate::eval::report::censored_range`]).
pub const CENSORED_FEATURES: [&str; 2] = ["t60_s", "edt_s"];
/// A draw ratio within this factor of the recordings' counts as matching (±25 %).
pub const VELOCITY_TOLERANCE: f64 = 0.25;
/// Draws per exponent for the velocity ratio (as the fit's).
const VELOCITY_DRAWS: u64 = 8;

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

/// Judges the draws of `preset` (seeds `1..=draws`) against the held-out group's recordings
/// `held`: recognition by `classifier`, feature ranges, the discriminator, velocity layers.
/// `fitted_from`, `fitted_recordings` and `others_ranges` are left for the caller.
pub(super) fn judge_group(
    group: &str,
    held: &[&Measured],
    preset: &Preset,
    classifier: &Classifier,
    draws: usize,
    prov: &BTreeMap<String, Provenance>,
    observer: &dyn Observer,
) -> anyhow::Result<HeldOutGroup> {
    let material = preset.material_class.as_str();
    let prov_of = |m: &Measured| provenance(prov, &m.label.path).cloned().unwrap_or_default();
    let distinct = distinct_recordings(held, prov);
    let seconds = seconds_like(held.iter().map(|m| m.duration_s));
    let feats: Vec<Option<SoundFeatures>> = (1..=draws as u64)
        .into_par_iter()
        .map(|seed| {
            let f = features::sound_features(&render_draw(preset, seed, seconds), RENDER_FS).ok();
            observer.advanced("draw", 1);
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
    let (features, range_skipped) =
        feature_ranges(&distinct, &ok, &|m| prov_of(m).edited, &|m| censored(m, prov));
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
    Ok(HeldOutGroup {
        held_out: group.to_owned(),
        recordings: distinct.len(),
        fitted_from: Vec::new(),
        fitted_recordings: 0,
        contact_exponent: preset.contact_exponent,
        recordings_recognised,
        draws,
        recognised,
        nearest_families: nearest,
        features,
        range_skipped,
        others_ranges: Vec::new(),
        others_censored: Vec::new(),
        discriminator,
        velocity: velocity_check(&paths, preset)?,
    })
}

/// The recordings of `measured` that are not a gain copy of another (`same_recording_as`): a
/// range or a discriminator counts each recording once.
fn distinct_recordings<'a>(
    measured: &[&'a Measured],
    prov: &BTreeMap<String, Provenance>,
) -> Vec<&'a Measured> {
    measured
        .iter()
        .copied()
        .filter(|m| provenance(prov, &m.label.path).is_none_or(|p| p.same_recording_as.is_none()))
        .collect()
}

/// Whether `m`'s decay is censored: by its manifest's end condition where that says, else by
/// its signal ([`Measured::ends_ringing`]).
pub fn censored(m: &Measured, prov: &BTreeMap<String, Provenance>) -> bool {
    provenance(prov, &m.label.path)
        .and_then(|p| p.censored)
        .unwrap_or(m.ends_ringing)
}

/// The values of feature `j` (named `name`) a range is taken from: every recording of
/// `distinct`, less the `edited` ones for the decay features other than the ring times
/// ([`CENSORED_FEATURES`]); with each value, whether it is censored (ring times only).
fn usable(
    distinct: &[&Measured],
    j: usize,
    name: &str,
    edited: &dyn Fn(&Measured) -> bool,
    censored: &dyn Fn(&Measured) -> bool,
) -> (Vec<f64>, Vec<bool>) {
    let ring = CENSORED_FEATURES.contains(&name);
    distinct
        .iter()
        .filter(|m| ring || !(DECAY_FEATURES.contains(&name) && edited(m)))
        .map(|m| (m.features.values()[j], ring && censored(m)))
        .unzip()
}

/// Per feature, the draws' median (of `draws`) against the 10–90 % range of the recordings
/// `distinct`, or why it is not judged: fewer than [`MIN_RANGE_RECORDINGS`] usable recordings,
/// where the decay features leave out `edited` ones, and the ring times count `censored` ones
/// as lower bounds ([`crate::eval::report::censored_range`]).
#[allow(clippy::type_complexity)]
fn feature_ranges(
    distinct: &[&Measured],
    draws: &[&SoundFeatures],
    edited: &dyn Fn(&Measured) -> bool,
    censored: &dyn Fn(&Measured) -> bool,
) -> (Vec<Option<FeatureCheck>>, Vec<Option<String>>) {
    let (mut features, mut range_skipped) = (Vec::new(), Vec::new());
    for (j, name) in FEATURE_NAMES.iter().enumerate() {
        let (usable, cut) = usable(distinct, j, name, edited, censored);
        if usable.len() < MIN_RANGE_RECORDINGS {
            features.push(None);
            range_skipped.push(Some(format!(
                "SKIPPED: {} usable recording{} (need {MIN_RANGE_RECORDINGS}{})",
                usable.len(),
                if usable.len() == 1 { "" } else { "s" },
                if DECAY_FEATURES.contains(name) && !CENSORED_FEATURES.contains(name) {
                    "; faded or truncated ones left out"
                } else {
                    ""
                }
            )));
            continue;
        }
        let d: Vec<f64> = draws.iter().map(|f| f.values()[j]).collect();
        features.push(Some(FeatureCheck::of_censored(name, &d, &usable, &cut)));
        range_skipped.push(None);
    }
    (features, range_skipped)
}

/// Per feature, the 10–90 % range ([`RANGE_PERCENTILES`](crate::eval::RANGE_PERCENTILES))
/// of the recordings of the *other* groups, `others` (the ones the fold's preset was fitted from,
/// every layer of them, selected and with censored ring times treated as [`feature_ranges`]
/// does the held-out group's), and how many of them are censored; the range `None` from fewer
/// than [`MIN_RANGE_RECORDINGS`]. Why: a held-out range that lies wholly outside it asks the
/// fit for a sound none of its recordings has (docs/evaluation.md, "Leave one family out").
pub(super) fn others_ranges(
    others: &[&Measured],
    prov: &BTreeMap<String, Provenance>,
) -> (Vec<Option<(f64, f64)>>, Vec<usize>) {
    let prov_of = |m: &Measured| provenance(prov, &m.label.path).cloned().unwrap_or_default();
    let distinct = distinct_recordings(others, prov);
    FEATURE_NAMES
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let (v, cut) = usable(&distinct, j, name, &|m| prov_of(m).edited, &|m| censored(m, prov));
            (
                (v.len() >= MIN_RANGE_RECORDINGS).then(|| crate::eval::report::censored_range(&v, &cut)),
                cut.iter().filter(|&&c| c).count(),
            )
        })
        .unzip()
}

/// The velocity check of the layered objects among the recordings at `paths`; `None` without
/// any.
fn velocity_check(paths: &[PathBuf], preset: &Preset) -> anyhow::Result<Option<VelocityCheck>> {
    let objects = velocity::layered_objects(paths)?;
    if objects.is_empty() {
        return Ok(None);
    }
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
    Ok(Some(VelocityCheck {
        objects: objects.len(),
        recorded_ratio: recorded,
        drawn_ratio: drawn,
        within: (drawn / recorded - 1.0).abs() <= VELOCITY_TOLERANCE,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
