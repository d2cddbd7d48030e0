//! `tactus eval`: do a preset's draws sound like the recordings? (docs/evaluation.md)
//!
//! 1. Every recording of a labelled folder and every draw of each preset (default settings, one
//!    1 m/s hit on a new object, seeds `1..=N`, rendered by the real [`Engine`](crate::engine::Engine)) is measured by
//!    the same function, [`features::sound_features`].
//! 2. A nearest-class-mean classifier on standardised features (z-scores of the training
//!    recordings) is trained on the recordings' material classes. The recordings' own recognition
//!    is measured leaving out the whole family of each recording (a marimba is judged by a
//!    classifier that never heard a marimba), the draws' recognition with all recordings.
//! 3. Per feature, the draws' median is compared with the recordings' 10–90 % range (of the
//!    preset's family when it was fitted from one family, else of its material class).

use crate::fit::audio;
pub use crate::fit::draws::{render_draw, render_one_hit, RENDER_FS, RENDER_S};
use crate::fit::features::{self, SoundFeatures, FEATURE_NAMES, N_FEATURES};
pub use crate::fit::labels::{label_folder, normalise_label, Labelled, Skipped};
use crate::preset::Preset;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Default number of draws per preset.
pub const DEFAULT_DRAWS: usize = 30;
/// Percentiles of the recordings' range a draw median must lie in.
pub const RANGE_PERCENTILES: (f64, f64) = (0.10, 0.90);

/// A measured recording.
#[derive(Debug, Clone, Serialize)]
pub struct Measured {
    /// Labels.
    #[serde(flatten)]
    pub label: Labelled,
    /// Its features.
    pub features: SoundFeatures,
}

/// Measures every labelled recording (in parallel, order kept); unreadable files and files
/// without features are skipped with the reason. `tick` is called once per file.
pub fn measure_recordings(files: &[Labelled], tick: &(dyn Fn() + Sync)) -> (Vec<Measured>, Vec<Skipped>) {
    let results: Vec<Result<Measured, Skipped>> = files
        .par_iter()
        .map(|l| {
            let r = audio::read_wav(&l.path)
                .map_err(|e| format!("{e:#}").replace(&format!("{}: ", l.path.display()), ""))
                .and_then(|rec| {
                    features::sound_features(&rec.samples, rec.sample_rate)
                        .map_err(|e| format!("no features: {e}"))
                });
            tick();
            r.map(|features| Measured {
                label: l.clone(),
                features,
            })
            .map_err(|reason| Skipped {
                name: l.name.clone(),
                reason,
            })
        })
        .collect();
    let (mut ok, mut bad) = (Vec::new(), Vec::new());
    for r in results {
        match r {
            Ok(m) => ok.push(m),
            Err(s) => bad.push(s),
        }
    }
    (ok, bad)
}

/// Nearest class mean on z-scored feature vectors ([`SoundFeatures::vector`]).
#[derive(Debug, Clone, Serialize)]
pub struct Classifier {
    /// Mean of each coordinate over the training set.
    pub mean: [f64; N_FEATURES],
    /// Standard deviation of each coordinate over the training set (1 where it is 0).
    pub sd: [f64; N_FEATURES],
    /// Class names with their mean z-scored vector.
    pub classes: Vec<(String, [f64; N_FEATURES])>,
}

impl Classifier {
    /// Trains on `(class, features)` pairs; `None` without at least two classes.
    pub fn train<'a>(samples: impl IntoIterator<Item = (&'a str, &'a SoundFeatures)>) -> Option<Self> {
        let samples: Vec<(&str, [f64; N_FEATURES])> =
            samples.into_iter().map(|(c, f)| (c, f.vector())).collect();
        let n = samples.len() as f64;
        let mut mean = [0.0; N_FEATURES];
        let mut sd = [0.0; N_FEATURES];
        for j in 0..N_FEATURES {
            mean[j] = samples.iter().map(|s| s.1[j]).sum::<f64>() / n;
            let var = samples.iter().map(|s| (s.1[j] - mean[j]).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
            sd[j] = if var > 0.0 { var.sqrt() } else { 1.0 };
        }
        let mut by_class: BTreeMap<&str, Vec<[f64; N_FEATURES]>> = BTreeMap::new();
        for (c, v) in &samples {
            let z: [f64; N_FEATURES] = std::array::from_fn(|j| (v[j] - mean[j]) / sd[j]);
            by_class.entry(c).or_default().push(z);
        }
        if by_class.len() < 2 {
            return None;
        }
        let classes = by_class
            .into_iter()
            .map(|(c, zs)| {
                let m = std::array::from_fn(|j| zs.iter().map(|z| z[j]).sum::<f64>() / zs.len() as f64);
                (c.to_owned(), m)
            })
            .collect();
        Some(Classifier { mean, sd, classes })
    }

    /// The class whose mean is nearest (Euclidean distance of z-scores).
    pub fn classify(&self, f: &SoundFeatures) -> &str {
        let v = f.vector();
        let z: [f64; N_FEATURES] = std::array::from_fn(|j| (v[j] - self.mean[j]) / self.sd[j]);
        let d = |m: &[f64; N_FEATURES]| (0..N_FEATURES).map(|j| (z[j] - m[j]).powi(2)).sum::<f64>();
        self.classes
            .iter()
            .min_by(|a, b| d(&a.1).total_cmp(&d(&b.1)))
            .map(|c| c.0.as_str())
            .unwrap_or("")
    }
}

/// One recording judged by a classifier trained without its family.
#[derive(Debug, Clone, Serialize)]
pub struct HeldOut {
    /// File name.
    pub name: String,
    /// Its material.
    pub material: String,
    /// Its family.
    pub family: String,
    /// The class predicted, `None` when the rest holds fewer than two classes or lacks its own.
    pub predicted: Option<String>,
}

/// Recognised / judged per material.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Rate {
    /// Correctly classified.
    pub correct: usize,
    /// Judged.
    pub total: usize,
}

impl Rate {
    /// `correct / total` (NaN when nothing was judged).
    pub fn share(&self) -> f64 {
        self.correct as f64 / self.total as f64
    }
}

/// Leave-one-family-out recognition of the recordings.
pub fn leave_one_family_out(recs: &[Measured]) -> Vec<HeldOut> {
    recs.iter()
        .map(|r| {
            let train = recs
                .iter()
                .filter(|o| o.label.family != r.label.family)
                .map(|o| (o.label.material.as_str(), &o.features));
            let predicted = Classifier::train(train).and_then(|c| {
                c.classes
                    .iter()
                    .any(|k| k.0 == r.label.material)
                    .then(|| c.classify(&r.features).to_owned())
            });
            HeldOut {
                name: r.label.name.clone(),
                material: r.label.material.clone(),
                family: r.label.family.clone(),
                predicted,
            }
        })
        .collect()
}

/// Rates per material from held-out results (files without a prediction are not counted).
pub fn rates(held: &[HeldOut]) -> BTreeMap<String, Rate> {
    let mut out: BTreeMap<String, Rate> = BTreeMap::new();
    for h in held {
        if let Some(p) = &h.predicted {
            let r = out.entry(h.material.clone()).or_default();
            r.total += 1;
            r.correct += usize::from(*p == h.material);
        }
    }
    out
}

/// Linear-interpolation quantile (`q` in 0..=1) of `v`; NaN when empty.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s: Vec<f64> = v.to_vec();
    s.sort_by(f64::total_cmp);
    if s.is_empty() {
        return f64::NAN;
    }
    let x = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (i, frac) = (x.floor() as usize, x - x.floor());
    if i + 1 < s.len() {
        s[i] + frac * (s[i + 1] - s[i])
    } else {
        s[i]
    }
}

/// The recordings a preset is compared with.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", content = "label", rename_all = "lowercase")]
pub enum Reference {
    /// A family preset: the recordings of that family.
    Family(String),
    /// A material preset: the recordings of its material class.
    Material(String),
}

impl Reference {
    /// Recordings of this reference.
    pub fn members<'a>(&self, recs: &'a [Measured]) -> Vec<&'a Measured> {
        recs.iter()
            .filter(|r| match self {
                Reference::Family(f) => &r.label.family == f,
                Reference::Material(m) => &r.label.material == m,
            })
            .collect()
    }
}

impl std::fmt::Display for Reference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Reference::Family(x) => write!(f, "family {x}"),
            Reference::Material(x) => write!(f, "material {x}"),
        }
    }
}

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

/// One feature of a preset's draws against the recordings' range.
#[derive(Debug, Clone, Serialize)]
pub struct FeatureCheck {
    /// Feature name ([`FEATURE_NAMES`]).
    pub feature: String,
    /// Median over the draws.
    pub draws_median: f64,
    /// 10 % and 90 % quantiles over the draws.
    pub draws_p10: f64,
    /// See `draws_p10`.
    pub draws_p90: f64,
    /// The reference recordings' 10 % quantile.
    pub recordings_p10: f64,
    /// The reference recordings' 90 % quantile.
    pub recordings_p90: f64,
    /// `recordings_p10 ≤ draws_median ≤ recordings_p90`.
    pub inside: bool,
}

/// The evaluation of one preset.
#[derive(Debug, Clone, Serialize)]
pub struct PresetReport {
    /// Preset name.
    pub name: String,
    /// Its material class.
    pub material_class: String,
    /// Recordings its features are compared with.
    pub reference: Reference,
    /// Reference recordings.
    pub reference_count: usize,
    /// Draws rendered.
    pub draws: usize,
    /// Draws without features (counted as not recognised).
    pub without_features: Vec<Skipped>,
    /// Draws classified as the preset's material class; `None` when the recordings hold no such
    /// class.
    pub recognised: Option<usize>,
    /// Predicted class per seed `1..=draws` (`None`: no features).
    pub predicted: Vec<Option<String>>,
    /// Features of every draw (`None`: no features).
    pub draw_features: Vec<Option<SoundFeatures>>,
    /// Per-feature comparison with the reference recordings.
    pub features: Vec<FeatureCheck>,
}

impl PresetReport {
    /// Share of the draws recognised (NaN when there is no class to recognise).
    pub fn recognition(&self) -> f64 {
        self.recognised.map_or(f64::NAN, |c| c as f64 / self.draws as f64)
    }

    /// The check of `feature` (one of [`FEATURE_NAMES`]).
    pub fn check(&self, feature: &str) -> Option<&FeatureCheck> {
        self.features.iter().find(|c| c.feature == feature)
    }
}

/// The whole evaluation.
#[derive(Debug, Clone, Serialize)]
pub struct Report {
    /// Recordings folder.
    pub recordings_dir: String,
    /// Recordings measured.
    pub recordings: Vec<Measured>,
    /// Recordings left out, with reasons.
    pub skipped: Vec<Skipped>,
    /// Leave-one-family-out results per recording.
    pub held_out: Vec<HeldOut>,
    /// Leave-one-family-out recognition per material.
    pub recordings_recognition: BTreeMap<String, Rate>,
    /// The classifier trained on all recordings (applied to the draws).
    pub classifier: Classifier,
    /// Per preset.
    pub presets: Vec<PresetReport>,
}

/// Renders and judges `draws` draws of `preset` (seeds `1..=draws`, in parallel).
pub fn evaluate_preset(
    preset: &Preset,
    draws: usize,
    recs: &[Measured],
    labels: &[Labelled],
    classifier: &Classifier,
    tick: &(dyn Fn() + Sync),
) -> PresetReport {
    let feats: Vec<Result<SoundFeatures, String>> = (1..=draws as u64)
        .into_par_iter()
        .map(|seed| {
            let f = features::sound_features(&render_draw(preset, seed), RENDER_FS);
            tick();
            f
        })
        .collect();
    let class = normalise_label(&preset.material_class);
    let has_class = classifier.classes.iter().any(|c| c.0 == class);
    let predicted: Vec<Option<String>> = feats
        .iter()
        .map(|f| f.as_ref().ok().map(|f| classifier.classify(f).to_owned()))
        .collect();
    let recognised = has_class.then(|| predicted.iter().filter(|p| p.as_deref() == Some(&class)).count());
    let reference = reference_of(preset, labels);
    let members = reference.members(recs);
    let ok: Vec<&SoundFeatures> = feats.iter().filter_map(|f| f.as_ref().ok()).collect();
    let (lo, hi) = RANGE_PERCENTILES;
    let features = (0..N_FEATURES)
        .map(|j| {
            let d: Vec<f64> = ok.iter().map(|f| f.values()[j]).collect();
            let r: Vec<f64> = members.iter().map(|m| m.features.values()[j]).collect();
            let med = quantile(&d, 0.5);
            let (r10, r90) = (quantile(&r, lo), quantile(&r, hi));
            FeatureCheck {
                feature: FEATURE_NAMES[j].to_owned(),
                draws_median: med,
                draws_p10: quantile(&d, lo),
                draws_p90: quantile(&d, hi),
                recordings_p10: r10,
                recordings_p90: r90,
                inside: (r10..=r90).contains(&med),
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
        draw_features: feats.into_iter().map(Result::ok).collect(),
        features,
    }
}

/// Runs the evaluation of `presets` against the labelled recordings in `dir`.
/// `progress(done, total)` is called as files and draws are measured.
pub fn evaluate(
    dir: &Path,
    presets: &[Preset],
    draws: usize,
    progress: &(dyn Fn(&str) + Sync),
) -> anyhow::Result<Report> {
    let (labels, mut skipped) = label_folder(dir)?;
    let (recordings, bad) = measure_recordings(&labels, &|| progress("recording"));
    skipped.extend(bad);
    let classifier = Classifier::train(
        recordings
            .iter()
            .map(|r| (r.label.material.as_str(), &r.features)),
    )
    .ok_or_else(|| {
        anyhow::anyhow!(
            "{}: the measured recordings hold fewer than two material classes; nothing to discriminate",
            dir.display()
        )
    })?;
    let held_out = leave_one_family_out(&recordings);
    let recordings_recognition = rates(&held_out);
    let presets = presets
        .iter()
        .map(|p| evaluate_preset(p, draws, &recordings, &labels, &classifier, &|| progress("draw")))
        .collect();
    Ok(Report {
        recordings_dir: dir.display().to_string(),
        recordings,
        skipped,
        held_out,
        recordings_recognition,
        classifier,
        presets,
    })
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

/// Writes the human-readable report.
pub fn write_table(out: &mut dyn std::io::Write, r: &Report) -> std::io::Result<()> {
    writeln!(
        out,
        "recordings: {} measured in {}, {} left out",
        r.recordings.len(),
        r.recordings_dir,
        r.skipped.len()
    )?;
    for s in &r.skipped {
        writeln!(out, "  left out {}: {}", s.name, s.reason)?;
    }
    writeln!(
        out,
        "\nrecordings recognised, leave-one-family-out (nearest class mean, z-scored features):"
    )?;
    for (m, rate) in &r.recordings_recognition {
        writeln!(
            out,
            "  {m:<10} {}/{} = {:.0} %",
            rate.correct,
            rate.total,
            100.0 * rate.share()
        )?;
    }
    for h in r
        .held_out
        .iter()
        .filter(|h| h.predicted.as_deref() != Some(&h.material))
    {
        writeln!(
            out,
            "    {} ({}, {}) -> {}",
            h.name,
            h.material,
            h.family,
            h.predicted.as_deref().unwrap_or("not judged")
        )?;
    }
    for p in &r.presets {
        writeln!(
            out,
            "\n{} ({}): {} draws, recognised as {}: {}; {} without features; compared with {} ({} recordings)",
            p.name,
            p.material_class,
            p.draws,
            p.material_class,
            match p.recognised {
                Some(c) => format!("{c}/{} = {:.0} %", p.draws, 100.0 * p.recognition()),
                None => "n/a (no such class in the recordings)".into(),
            },
            p.without_features.len(),
            p.reference,
            p.reference_count
        )?;
        writeln!(
            out,
            "  {:<14} {:>10} {:>23} {:>23}  verdict",
            "feature", "draws med", "draws 10-90 %", "recordings 10-90 %"
        )?;
        for c in &p.features {
            writeln!(
                out,
                "  {:<14} {:>10} {:>10} .. {:<10} {:>10} .. {:<10}  {}",
                c.feature,
                fmt(c.draws_median),
                fmt(c.draws_p10),
                fmt(c.draws_p90),
                fmt(c.recordings_p10),
                fmt(c.recordings_p90),
                if c.inside { "inside" } else { "OUTSIDE" }
            )?;
        }
        for s in &p.without_features {
            writeln!(out, "  {}: no features ({})", s.name, s.reason)?;
        }
    }
    Ok(())
}

/// Four significant digits, scientific for very small values.
fn fmt(v: f64) -> String {
    if v.is_nan() {
        "-".into()
    } else if v != 0.0 && v.abs() < 0.01 {
        format!("{v:.3e}")
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

/// `tactus eval`.
pub fn run(
    dir: &Path,
    preset_args: &[String],
    draws: usize,
    json: Option<&Path>,
    spectrograms: Option<&Path>,
) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    if draws == 0 {
        anyhow::bail!("--draws must be at least 1");
    }
    let presets = resolve_presets(preset_args)?;
    if presets.is_empty() {
        anyhow::bail!("no presets to evaluate (no built-in fitted presets; give --preset)");
    }
    // Fail on unwritable outputs before minutes of work.
    if let Some(p) = json {
        std::fs::File::create(p).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", p.display()))?;
    }
    if let Some(d) = spectrograms {
        std::fs::create_dir_all(d).map_err(|e| anyhow::anyhow!("cannot create {}: {e}", d.display()))?;
    }
    let (labels, _) = label_folder(dir)?;
    let total = (labels.len() + presets.len() * draws) as u64;
    let bar = indicatif::ProgressBar::new(total);
    if std::io::stderr().is_terminal() {
        bar.set_style(
            indicatif::ProgressStyle::with_template("evaluating {bar:40} {pos}/{len} ({msg}) eta {eta}")
                .expect("valid template"),
        );
    } else {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
        eprintln!(
            "evaluating {} recordings and {} draws of {} presets",
            labels.len(),
            presets.len() * draws,
            presets.len()
        );
    }
    let report = evaluate(dir, &presets, draws, &|what| {
        bar.set_message(what.to_owned());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match write_table(&mut out, &report).and_then(|()| std::io::Write::flush(&mut out)) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        r => r.map_err(|e| anyhow::anyhow!("cannot write to stdout: {e}"))?,
    }
    if let Some(p) = json {
        let text = serde_json::to_string_pretty(&report).map_err(|e| anyhow::anyhow!("{e}"))?;
        std::fs::write(p, text + "\n").map_err(|e| anyhow::anyhow!("cannot write {}: {e}", p.display()))?;
        eprintln!("wrote {}", p.display());
    }
    if let Some(d) = spectrograms {
        for (preset, pr) in presets.iter().zip(&report.presets) {
            let path = d.join(format!("{}.png", crate::fit::spectrogram::slug(&preset.name)));
            let members = pr.reference.members(&report.recordings);
            let Some(rec) = representative(&members) else {
                eprintln!("{}: no recording of its {} to show", preset.name, pr.reference);
                continue;
            };
            crate::fit::spectrogram::write_comparison(&path, &rec.label.path, preset)?;
            eprintln!("wrote {} ({} beside draws 1-3)", path.display(), rec.label.name);
        }
    }
    Ok(())
}

/// The member nearest to the members' mean feature vector (standardised by their own spread):
/// a typical recording to show beside the draws.
fn representative<'a>(members: &[&'a Measured]) -> Option<&'a Measured> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_normalise_and_quantiles_interpolate() {
        assert_eq!(normalise_label(" Wood-Block "), "wood block");
        assert_eq!(normalise_label("steel_drum"), "steel drum");
        assert_eq!(quantile(&[3.0, 1.0, 2.0, 4.0], 0.5), 2.5);
        assert!((quantile(&[0.0, 10.0], 0.1) - 1.0).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_nan());
    }
}
