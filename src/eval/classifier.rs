//! The material classifier of `tactus eval`: nearest family mean on standardised features
//! (z-scores of the training recordings), and the recordings' own recognition with each
//! recording's whole family left out of the training (a marimba is judged by a classifier that
//! never heard a marimba).
//!
//! A material is a mixture of families (a cowbell and a crash cymbal are both metal, and far
//! apart), so one mean per material lands between its families, near none of them: a cowbell
//! is then nearer the wood mean than the cymbal-heavy metal one. Each family keeps its own
//! centre, and a sound takes the material of the nearest. Measured on the development
//! recordings (docs/evaluation.md, "Classifier"), this recognises more held-out families than
//! one mean per material, and each family counts once, whatever its number of recordings.

use crate::analysis::features::{Measured, SoundFeatures, N_FEATURES};
use serde::Serialize;
use std::collections::BTreeMap;

/// One family's centre: the mean of its recordings' z-scored feature vectors.
#[derive(Debug, Clone, Serialize)]
pub struct Centre {
    /// The material class the family belongs to.
    pub class: String,
    /// The family.
    pub family: String,
    /// Mean z-scored vector of the family's training recordings.
    pub mean: [f64; N_FEATURES],
}

/// Nearest family mean on z-scored feature vectors ([`SoundFeatures::vector`]).
#[derive(Debug, Clone, Serialize)]
pub struct Classifier {
    /// Mean of each coordinate over the training set.
    pub mean: [f64; N_FEATURES],
    /// Standard deviation of each coordinate over the training set (1 where it is 0).
    pub sd: [f64; N_FEATURES],
    /// Each family's centre, with its class.
    pub centres: Vec<Centre>,
}

impl Classifier {
    /// Trains on `(class, family, features)` triples; `None` without at least two classes.
    pub fn train<'a>(
        samples: impl IntoIterator<Item = (&'a str, &'a str, &'a SoundFeatures)>,
    ) -> Option<Self> {
        let samples: Vec<(&str, &str, [f64; N_FEATURES])> = samples
            .into_iter()
            .map(|(c, fam, f)| (c, fam, f.vector()))
            .collect();
        let n = samples.len() as f64;
        let mut mean = [0.0; N_FEATURES];
        let mut sd = [0.0; N_FEATURES];
        for j in 0..N_FEATURES {
            mean[j] = samples.iter().map(|s| s.2[j]).sum::<f64>() / n;
            let var = samples.iter().map(|s| (s.2[j] - mean[j]).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
            sd[j] = if var > 0.0 { var.sqrt() } else { 1.0 };
        }
        let mut by_family: BTreeMap<(&str, &str), Vec<[f64; N_FEATURES]>> = BTreeMap::new();
        for (c, fam, v) in &samples {
            let z: [f64; N_FEATURES] = std::array::from_fn(|j| (v[j] - mean[j]) / sd[j]);
            by_family.entry((c, fam)).or_default().push(z);
        }
        let centres: Vec<Centre> = by_family
            .into_iter()
            .map(|((c, fam), zs)| Centre {
                class: c.to_owned(),
                family: fam.to_owned(),
                mean: std::array::from_fn(|j| zs.iter().map(|z| z[j]).sum::<f64>() / zs.len() as f64),
            })
            .collect();
        let c = Classifier { mean, sd, centres };
        (c.classes().len() >= 2).then_some(c)
    }

    /// The material classes it knows, sorted.
    pub fn classes(&self) -> Vec<&str> {
        let mut out: Vec<&str> = self.centres.iter().map(|c| c.class.as_str()).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether `class` is among the classes it was trained on.
    pub fn knows(&self, class: &str) -> bool {
        self.centres.iter().any(|c| c.class == class)
    }

    /// The family centre nearest `f` (Euclidean distance of z-scores).
    pub fn nearest(&self, f: &SoundFeatures) -> Option<&Centre> {
        let v = f.vector();
        let z: [f64; N_FEATURES] = std::array::from_fn(|j| (v[j] - self.mean[j]) / self.sd[j]);
        let d = |m: &[f64; N_FEATURES]| (0..N_FEATURES).map(|j| (z[j] - m[j]).powi(2)).sum::<f64>();
        self.centres
            .iter()
            .min_by(|a, b| d(&a.mean).total_cmp(&d(&b.mean)))
    }

    /// The class of the nearest family centre ([`Classifier::nearest`]).
    pub fn classify(&self, f: &SoundFeatures) -> &str {
        self.nearest(f).map_or("", |c| c.class.as_str())
    }
}

/// How many of a set of draws fell nearest one family's centre.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NearestFamily {
    /// The family.
    pub family: String,
    /// Its material class.
    pub class: String,
    /// Draws nearest its centre.
    pub draws: usize,
}

/// The family centres nearest a set of draws ([`Classifier::nearest`] of each), counted, most
/// draws first (ties in the centres' class and family order, so the list is stable).
pub fn nearest_families<'a>(nearest: impl IntoIterator<Item = &'a Centre>) -> Vec<NearestFamily> {
    let mut out: Vec<NearestFamily> = Vec::new();
    for c in nearest {
        match out
            .iter_mut()
            .find(|n| n.family == c.family && n.class == c.class)
        {
            Some(n) => n.draws += 1,
            None => out.push(NearestFamily {
                family: c.family.clone(),
                class: c.class.clone(),
                draws: 1,
            }),
        }
    }
    out.sort_by(|a, b| {
        b.draws
            .cmp(&a.draws)
            .then_with(|| (&a.class, &a.family).cmp(&(&b.class, &b.family)))
    });
    out
}

/// `family (class) draws, …` of [`nearest_families`], for the printed reports.
pub fn nearest_families_line(list: &[NearestFamily]) -> String {
    list.iter()
        .map(|n| format!("{} ({}) {}", n.family, n.class, n.draws))
        .collect::<Vec<_>>()
        .join(", ")
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
                .map(|o| (o.label.material.as_str(), o.label.family.as_str(), &o.features));
            let predicted = Classifier::train(train).and_then(|c| {
                c.knows(&r.label.material)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn sound(centroid_hz: f64, t60_s: f64) -> SoundFeatures {
        SoundFeatures {
            centroid_hz,
            tan_phi: 1e-3,
            t60_s,
            decay_slope: 0.2,
            attack_share: 0.1,
            edt_s: t60_s / 2.0,
            peak_count: 40.0,
        }
    }

    /// A material of two far-apart families (bells, bright; gongs, dark) on either side of a
    /// material between them (bars), all else equal. One mean per material sits among the six
    /// bells, so a new gong is nearer the bars' mean; with a centre per family it is placed by
    /// the gongs. This checks a new gong, bell and bar, each a little off its family, and that
    /// one mean per material would have misjudged the gong.
    #[test]
    fn each_family_keeps_its_own_centre() {
        let bells: Vec<SoundFeatures> = (0..6).map(|i| sound(8000.0 + 100.0 * i as f64, 0.5)).collect();
        let gongs: Vec<SoundFeatures> = (0..2).map(|i| sound(500.0 + 10.0 * i as f64, 0.5)).collect();
        let bars: Vec<SoundFeatures> = (0..4).map(|i| sound(2000.0 + 50.0 * i as f64, 0.5)).collect();
        let samples = bells
            .iter()
            .map(|f| ("metal", "bell", f))
            .chain(gongs.iter().map(|f| ("metal", "gong", f)))
            .chain(bars.iter().map(|f| ("wood", "bar", f)));
        let c = Classifier::train(samples).expect("two classes");
        assert_eq!(c.classes(), ["metal", "wood"]);
        assert_eq!(c.centres.len(), 3);
        assert_eq!(c.classify(&sound(520.0, 0.5)), "metal", "a new gong");
        assert_eq!(c.classify(&sound(8100.0, 0.5)), "metal", "a new bell");
        assert_eq!(c.classify(&sound(2100.0, 0.5)), "wood", "a new bar");

        // One mean per material: the family centres weighted by their recordings.
        let metal_mean: [f64; N_FEATURES] = std::array::from_fn(|j| {
            let zs: Vec<f64> = c
                .centres
                .iter()
                .filter(|k| k.class == "metal")
                .map(|k| k.mean[j] * if k.family == "bell" { 6.0 } else { 2.0 })
                .collect();
            zs.iter().sum::<f64>() / 8.0
        });
        let wood = &c.centres.iter().find(|k| k.class == "wood").unwrap().mean;
        let v = sound(520.0, 0.5).vector();
        let z: [f64; N_FEATURES] = std::array::from_fn(|j| (v[j] - c.mean[j]) / c.sd[j]);
        let d = |m: &[f64; N_FEATURES]| (0..N_FEATURES).map(|j| (z[j] - m[j]).powi(2)).sum::<f64>();
        assert!(
            d(wood) < d(&metal_mean),
            "one mean per material would call the gong wood"
        );

        // Three draws near the gongs, one near the bars: gongs first, counts per family.
        let draws = [
            sound(510.0, 0.5),
            sound(490.0, 0.5),
            sound(505.0, 0.5),
            sound(2050.0, 0.5),
        ];
        let near = nearest_families(draws.iter().filter_map(|f| c.nearest(f)));
        let got: Vec<(&str, &str, usize)> = near
            .iter()
            .map(|n| (n.family.as_str(), n.class.as_str(), n.draws))
            .collect();
        assert_eq!(got, [("gong", "metal", 3), ("bar", "wood", 1)]);
        assert_eq!(nearest_families_line(&near), "gong (metal) 3, bar (wood) 1");

        // One class left: no classifier.
        assert!(Classifier::train(bells.iter().map(|f| ("metal", "bell", f))).is_none());
    }
}
