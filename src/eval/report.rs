//! What `tactus eval` found, as data (the `--json` report) and as the table it prints: per
//! preset, the recordings it is compared with, its draws' recognition and each feature's draw
//! median against the recordings' range.

use crate::analysis::features::{Measured, SoundFeatures};
use crate::analysis::labels::Skipped;
use crate::eval::classifier::{nearest_families_line, Classifier, HeldOut, NearestFamily, Rate};
use serde::Serialize;
use std::collections::BTreeMap;

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

/// One feature of a preset's draws against the recordings' range.
#[derive(Debug, Clone, Serialize)]
pub struct FeatureCheck {
    /// Feature name ([`FEATURE_NAMES`](crate::analysis::features::FEATURE_NAMES)).
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
    /// Of the recordings the range is taken from, those whose decay is censored (they end
    /// still ringing: [`crate::analysis::censoring`]) and so count as lower bounds; 0 where
    /// the range treats none as censored.
    pub censored: usize,
}

impl FeatureCheck {
    /// The draws' values of `feature` against the recordings' 10–90 % range
    /// ([`RANGE_PERCENTILES`](crate::eval::RANGE_PERCENTILES)).
    pub fn of(feature: &str, draws: &[f64], recordings: &[f64]) -> Self {
        use crate::stats::quantile;
        let (lo, hi) = crate::eval::RANGE_PERCENTILES;
        Self::within(
            feature,
            draws,
            (quantile(recordings, lo), quantile(recordings, hi)),
            0,
        )
    }

    /// The draws' values of `feature` against the range of `recordings` that counts those with
    /// `censored` set as lower bounds ([`censored_range`]).
    pub fn of_censored(feature: &str, draws: &[f64], recordings: &[f64], censored: &[bool]) -> Self {
        let n = censored.iter().filter(|&&c| c).count();
        Self::within(feature, draws, censored_range(recordings, censored), n)
    }

    fn within(feature: &str, draws: &[f64], (r10, r90): (f64, f64), censored: usize) -> Self {
        use crate::stats::quantile;
        let (lo, hi) = crate::eval::RANGE_PERCENTILES;
        let med = quantile(draws, 0.5);
        FeatureCheck {
            feature: feature.to_owned(),
            draws_median: med,
            draws_p10: quantile(draws, lo),
            draws_p90: quantile(draws, hi),
            recordings_p10: r10,
            recordings_p90: r90,
            inside: (r10..=r90).contains(&med),
            censored,
        }
    }
}

/// The 10–90 % range of a positive decay feature (a ring time: T60, EDT) over `values`, those
/// with `censored` set being lower bounds (docs/evaluation.md, "Censored decays"). Without a
/// censored value, the values' own quantiles. With some, the quantiles of the censored (Tobit)
/// normal fit of their logarithms ([`crate::fit::pool::censored::fit`]), as the fit pools ring
/// times; where fewer than 2 distinct values rang out that fit is not placed, and the range is
/// open above: from the 10 % quantile of the values (the object's is no lower) to infinity.
pub fn censored_range(values: &[f64], censored: &[bool]) -> (f64, f64) {
    use crate::stats::quantile;
    let (lo, hi) = crate::eval::RANGE_PERCENTILES;
    if !censored.iter().any(|&c| c) {
        return (quantile(values, lo), quantile(values, hi));
    }
    let logs: Vec<f64> = values.iter().map(|v| v.ln()).collect();
    match crate::fit::pool::censored::fit(&logs, censored) {
        Some(f) => {
            let (a, b) = f.range_10_90();
            (a.exp(), b.exp())
        }
        None => (quantile(values, lo), f64::INFINITY),
    }
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
    /// The family centres the draws fell nearest, most draws first: which recorded families
    /// the draws sound like, and so why a draw is or is not recognised.
    pub nearest_families: Vec<NearestFamily>,
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

    /// The check of `feature` (one of [`FEATURE_NAMES`](crate::analysis::features::FEATURE_NAMES)).
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
        "\nrecordings recognised, leave-one-family-out (nearest family mean, z-scored features):"
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
        if !p.nearest_families.is_empty() {
            writeln!(
                out,
                "  draws nearest the family centres of: {}",
                nearest_families_line(&p.nearest_families)
            )?;
        }
        writeln!(
            out,
            "  {:<14} {:>10} {:>23} {:>23}  verdict",
            "feature", "draws med", "draws 10-90 %", "recordings 10-90 %"
        )?;
        for c in &p.features {
            write!(
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
            if c.censored > 0 {
                write!(out, " ({}/{} censored)", c.censored, p.reference_count)?;
            }
            writeln!(out)?;
        }
        for s in &p.without_features {
            writeln!(out, "  {}: no features ({})", s.name, s.reason)?;
        }
    }
    Ok(())
}

/// Four significant digits, scientific for very small values.
pub(crate) fn fmt(v: f64) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Uncensored values give their own quantiles; censored ones only widen the range upward;
    /// too few values that rang out leave it open above.
    #[test]
    fn a_censored_range_reaches_beyond_its_bounds() {
        let v = [1.0, 1.5, 2.0, 2.5, 3.0];
        let plain = censored_range(&v, &[false; 5]);
        assert!((plain.0 - 1.2).abs() < 1e-12 && (plain.1 - 2.8).abs() < 1e-12);
        let all_exact = censored_range(&v, &[false; 5]);
        let cut = censored_range(&v, &[false, false, false, true, true]);
        assert!(cut.1 > all_exact.1, "{cut:?} vs {all_exact:?}");
        let open = censored_range(&v, &[true, true, true, true, false]);
        assert_eq!(open, (1.2, f64::INFINITY));
        let c = FeatureCheck::of_censored("t60_s", &[10.0], &v, &[true, true, true, true, false]);
        assert!(c.inside && c.censored == 4, "{c:?}");
    }
}
