//! `tactus eval --components`: each component of a fitted mixture, drawn alone, against the
//! one recording it was fitted from (docs/evaluation.md, "Components against their
//! recordings").
//!
//! A family preset's draws are judged against its family's range, which a preset can meet
//! while each of its components sounds unlike its own recording (one rings too long, another
//! too short). A component is fitted from one recording, so its draws, with their size shift and
//! kernel spread, should sound like that recording: the median of each feature over its draws
//! is compared with the recording's value ([`deviation`]: a log ratio, or for the signed decay
//! slope a difference), and the preset is summarised by the median of those deviations over its
//! components (its bias) and of their magnitudes (its error).

use super::report::fmt;
use crate::analysis::features::{measure_recordings, SoundFeatures, FEATURE_NAMES, N_FEATURES};
use crate::analysis::render::{render_draw, seconds_like, RENDER_FS};
use crate::preset::Preset;
use crate::stats::median;
use crate::work::Observer;
use rayon::prelude::*;
use serde::Serialize;
use std::path::PathBuf;

/// One component drawn alone against its recording.
#[derive(Debug, Clone, Serialize)]
pub struct ComponentReport {
    /// The component's name in its preset (`<family>: <recording>`).
    pub component: String,
    /// The recording it was fitted from.
    pub recording: String,
    /// Draws with features (of the draws asked for).
    pub measured_draws: usize,
    /// Per feature ([`FEATURE_NAMES`]): the draws' median, the recording's value and their
    /// [`deviation`].
    pub features: Vec<ComponentFeature>,
}

/// One feature of a component's draws against its recording.
#[derive(Debug, Clone, Serialize)]
pub struct ComponentFeature {
    /// Feature name.
    pub feature: String,
    /// Median over the component's draws.
    pub draws_median: f64,
    /// The recording's value.
    pub recording: f64,
    /// [`deviation`] of the draws' median from the recording's value.
    pub deviation: Option<f64>,
}

/// The feature whose values are signed ([`FEATURE_NAMES`]): 0 when every partial rings as long,
/// negative when the high ones ring longer.
const SIGNED_FEATURE: &str = "decay_slope";

/// How far a component's draws lie from its recording in `feature`: `draws − recording` for the
/// signed decay slope, `ln(draws / recording)` for every other feature (positive, spanning
/// decades: +0.41 is 1.5 times); `None` where that is undefined (a value not finite, or a
/// ratio of values not both positive). Why not a ratio for the slope: a slope near 0 or of the
/// other sign has none, and leaving those components out would judge a preset on the others.
pub fn deviation(feature: &str, draws: f64, recording: f64) -> Option<f64> {
    let d = if feature == SIGNED_FEATURE {
        draws - recording
    } else if draws > 0.0 && recording > 0.0 {
        (draws / recording).ln()
    } else {
        return None;
    };
    d.is_finite().then_some(d)
}

/// A preset's components against their recordings.
#[derive(Debug, Clone, Serialize)]
pub struct PresetComponents {
    /// Preset name.
    pub preset: String,
    /// Its components whose recording was found and measured.
    pub components: Vec<ComponentReport>,
    /// Components left out, with the reason.
    pub left_out: Vec<String>,
    /// Per feature, over the components.
    pub summary: Vec<FeatureSummary>,
}

/// One feature over a preset's components.
#[derive(Debug, Clone, Serialize)]
pub struct FeatureSummary {
    /// Feature name.
    pub feature: String,
    /// Median of the components' deviations; `None` without one.
    pub bias: Option<f64>,
    /// Median of their magnitudes; `None` without one.
    pub error: Option<f64>,
}

/// The recording file a component is named after: the text after its last `": "`.
pub fn component_recording(name: &str) -> Option<&str> {
    name.rsplit_once(": ")
        .map(|(_, file)| file)
        .filter(|f| !f.is_empty())
}

/// `preset` with `family` its only component (weight 1).
fn alone(preset: &Preset, family: usize) -> Preset {
    let mut p = preset.clone();
    let mut f = p.families[family].clone();
    f.weight = 1.0;
    p.families = vec![f];
    p
}

/// Draws each component of each of `presets` alone `draws` times (seeds `1..=draws`, as long as
/// its recording) and compares the draws' feature medians with its recording's features. The
/// recordings are looked up by file name among the labelled folders `dirs`.
pub fn evaluate_components(
    dirs: &[PathBuf],
    presets: &[Preset],
    draws: usize,
    observer: &dyn Observer,
) -> anyhow::Result<Vec<PresetComponents>> {
    let (labels, _) = super::label_folders(dirs)?;
    let wanted: Vec<&str> = presets
        .iter()
        .flat_map(|p| p.families.iter().filter_map(|f| component_recording(&f.name)))
        .collect();
    let used: Vec<_> = labels
        .iter()
        .filter(|l| wanted.contains(&l.name.as_str()))
        .cloned()
        .collect();
    observer.started((used.len() + wanted.len() * draws) as u64);
    let (recordings, bad) = measure_recordings(&used, observer);
    let mut out = Vec::new();
    for preset in presets {
        let mut report = PresetComponents {
            preset: preset.name.clone(),
            components: Vec::new(),
            left_out: Vec::new(),
            summary: Vec::new(),
        };
        if preset.families.is_empty() {
            report
                .left_out
                .push("no mixture components (a preset without families)".into());
        }
        for (j, family) in preset.families.iter().enumerate() {
            let Some(file) = component_recording(&family.name) else {
                report
                    .left_out
                    .push(format!("{}: not named after a recording", family.name));
                continue;
            };
            let Some(rec) = recordings.iter().find(|r| r.label.name == file) else {
                let why = bad
                    .iter()
                    .find(|s| s.name == file)
                    .map_or("not among the labelled recordings".to_owned(), |s| {
                        s.reason.clone()
                    });
                report.left_out.push(format!("{}: {file}: {why}", family.name));
                continue;
            };
            let p = alone(preset, j);
            let seconds = seconds_like([rec.duration_s]);
            let feats: Vec<SoundFeatures> = (1..=draws as u64)
                .into_par_iter()
                .filter_map(|seed| {
                    let f =
                        crate::analysis::features::sound_features(&render_draw(&p, seed, seconds), RENDER_FS);
                    observer.advanced("draw", 1);
                    f.ok()
                })
                .collect();
            if feats.is_empty() {
                report
                    .left_out
                    .push(format!("{}: no draw has features", family.name));
                continue;
            }
            let features = (0..N_FEATURES)
                .map(|k| {
                    let d = median(&feats.iter().map(|f| f.values()[k]).collect::<Vec<_>>());
                    let r = rec.features.values()[k];
                    ComponentFeature {
                        feature: FEATURE_NAMES[k].to_owned(),
                        draws_median: d,
                        recording: r,
                        deviation: deviation(FEATURE_NAMES[k], d, r),
                    }
                })
                .collect();
            report.components.push(ComponentReport {
                component: family.name.clone(),
                recording: file.to_owned(),
                measured_draws: feats.len(),
                features,
            });
        }
        report.summary = (0..N_FEATURES)
            .map(|k| {
                let r: Vec<f64> = report
                    .components
                    .iter()
                    .filter_map(|c| c.features[k].deviation)
                    .collect();
                let abs: Vec<f64> = r.iter().map(|v| v.abs()).collect();
                FeatureSummary {
                    feature: FEATURE_NAMES[k].to_owned(),
                    bias: (!r.is_empty()).then(|| median(&r)),
                    error: (!abs.is_empty()).then(|| median(&abs)),
                }
            })
            .collect();
        out.push(report);
    }
    Ok(out)
}

/// Prints the components' table: per component the draws' median over the recording's value
/// of each feature, then each preset's bias and error.
pub fn write_table(out: &mut dyn std::io::Write, reports: &[PresetComponents]) -> std::io::Result<()> {
    for r in reports {
        writeln!(
            out,
            "{}: {} components judged against their own recordings",
            r.preset,
            r.components.len()
        )?;
        write!(out, "  {:<52}", "component (draws' median / recording)")?;
        for name in FEATURE_NAMES {
            write!(out, " {name:>19}")?;
        }
        writeln!(out)?;
        for c in &r.components {
            let label: String = c.recording.chars().take(52).collect();
            write!(out, "  {label:<52}")?;
            for f in &c.features {
                write!(
                    out,
                    " {:>19}",
                    format!("{}/{}", fmt(f.draws_median), fmt(f.recording))
                )?;
            }
            writeln!(out)?;
        }
        for line in &r.left_out {
            writeln!(out, "  left out: {line}")?;
        }
        let signed = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:+.2}"));
        write!(out, "  {:<52}", "bias: median ln(draws/recording), slope d−r")?;
        for s in &r.summary {
            write!(out, " {:>19}", signed(s.bias))?;
        }
        writeln!(out)?;
        write!(out, "  {:<52}", "error: median |ln(draws/recording)|, |d−r|")?;
        for s in &r.summary {
            write!(
                out,
                " {:>19}",
                s.error.map_or("-".to_owned(), |v| format!("{v:.2}"))
            )?;
        }
        writeln!(out)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_slope_deviates_by_difference_and_the_others_by_log_ratio() {
        // A slope of the other sign, or near 0, still counts (and its sign says which way).
        assert_eq!(deviation("decay_slope", -0.25, 0.07), Some(-0.32));
        assert_eq!(deviation("decay_slope", 0.0, 0.0), Some(0.0));
        let r = deviation("t60_s", 4.5, 3.0).expect("both positive");
        assert!((r - 1.5f64.ln()).abs() < 1e-12);
        assert_eq!(deviation("t60_s", 0.0, 3.0), None);
        assert_eq!(deviation("centroid_hz", f64::NAN, 3000.0), None);
        assert_eq!(deviation("decay_slope", f64::INFINITY, 0.1), None);
    }

    #[test]
    fn a_component_is_named_after_its_recording() {
        assert_eq!(
            component_recording("crash cymbal: metal_crash-cymbal_bja-pacific_cb-03.wav"),
            Some("metal_crash-cymbal_bja-pacific_cb-03.wav")
        );
        assert_eq!(component_recording("wood"), None);
        assert_eq!(component_recording("wood: "), None);
    }
}
