//! The material classifier of `tactus eval`: nearest class mean on standardised features
//! (z-scores of the training recordings), and the recordings' own recognition with each
//! recording's whole family left out of the training (a marimba is judged by a classifier that
//! never heard a marimba).

use crate::eval::features::{Measured, SoundFeatures, N_FEATURES};
use serde::Serialize;
use std::collections::BTreeMap;

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
