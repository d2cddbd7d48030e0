//! Confusion matrices and a nearest-centre classifier on plain feature vectors, for the
//! measured materials' and surfaces' recognition checks (docs/measured.md). The material
//! classifier of `tactus eval` ([`super::classifier::Classifier`]) is tied to the impact
//! features; scrapes have feature vectors of their own length (band levels), judged here the
//! same way: z-scores of the training set, each label's centre the mean of its z-scored vectors.

use serde::Serialize;
use std::fmt::Write as _;

/// Counts of (true label, predicted label), both indices into `labels`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Confusion {
    /// Label names, in row and column order.
    pub labels: Vec<String>,
    /// `counts[true][predicted]`.
    pub counts: Vec<Vec<usize>>,
}

impl Confusion {
    /// An empty matrix over `labels`.
    pub fn new(labels: &[&str]) -> Self {
        Self {
            labels: labels.iter().map(|s| (*s).to_owned()).collect(),
            counts: vec![vec![0; labels.len()]; labels.len()],
        }
    }

    /// Counts one judgement.
    pub fn add(&mut self, truth: usize, predicted: usize) {
        self.counts[truth][predicted] += 1;
    }

    /// Judgements counted.
    pub fn total(&self) -> usize {
        self.counts.iter().flatten().sum()
    }

    /// Correct judgements (the diagonal).
    pub fn correct(&self) -> usize {
        (0..self.labels.len()).map(|i| self.counts[i][i]).sum()
    }

    /// Share correct (NaN when empty).
    pub fn share(&self) -> f64 {
        self.correct() as f64 / self.total() as f64
    }

    /// Share correct of the items of label `i` (NaN when it has none).
    pub fn recall(&self, i: usize) -> f64 {
        self.counts[i][i] as f64 / self.counts[i].iter().sum::<usize>() as f64
    }

    /// The matrix as a Markdown table: rows the true labels, columns the predicted ones (headed
    /// by `short` of each label), a last column with the row's share correct.
    pub fn markdown(&self, short: impl Fn(&str) -> String) -> String {
        let mut md = String::from("| true \\ judged |");
        for l in &self.labels {
            let _ = write!(md, " {} |", short(l));
        }
        md.push_str(" correct |\n|---|");
        md.push_str(&"---:|".repeat(self.labels.len() + 1));
        md.push('\n');
        for (i, row) in self.counts.iter().enumerate() {
            let _ = write!(md, "| {} |", self.labels[i]);
            for (j, &c) in row.iter().enumerate() {
                if i == j {
                    let _ = write!(md, " **{c}** |");
                } else if c == 0 {
                    md.push_str(" · |");
                } else {
                    let _ = write!(md, " {c} |");
                }
            }
            let _ = writeln!(md, " {:.0} % |", 100.0 * self.recall(i));
        }
        md
    }
}

/// Nearest label centre on z-scored vectors (the z-scores of the training set).
#[derive(Debug, Clone, Serialize)]
pub struct NearestCentre {
    /// Mean of each coordinate over the training set.
    pub mean: Vec<f64>,
    /// Standard deviation of each coordinate over the training set (1 where it is 0).
    pub sd: Vec<f64>,
    /// Per label (index), the mean z-scored vector of its training items; `None` without any.
    pub centres: Vec<Option<Vec<f64>>>,
}

impl NearestCentre {
    /// Trains on `(label, vector)` pairs, labels `0..labels`; `None` with fewer than 2 items.
    pub fn train<'a>(labels: usize, items: impl IntoIterator<Item = (usize, &'a [f64])>) -> Option<Self> {
        let items: Vec<(usize, &[f64])> = items.into_iter().collect();
        let dim = items.first()?.1.len();
        if items.len() < 2 {
            return None;
        }
        let n = items.len() as f64;
        let mean: Vec<f64> = (0..dim)
            .map(|j| items.iter().map(|x| x.1[j]).sum::<f64>() / n)
            .collect();
        let sd: Vec<f64> = (0..dim)
            .map(|j| {
                let v = items.iter().map(|x| (x.1[j] - mean[j]).powi(2)).sum::<f64>() / (n - 1.0);
                if v > 0.0 {
                    v.sqrt()
                } else {
                    1.0
                }
            })
            .collect();
        let mut sums = vec![(vec![0.0; dim], 0usize); labels];
        for (l, v) in &items {
            let s = &mut sums[*l];
            for j in 0..dim {
                s.0[j] += (v[j] - mean[j]) / sd[j];
            }
            s.1 += 1;
        }
        let centres = sums
            .into_iter()
            .map(|(s, k)| (k > 0).then(|| s.into_iter().map(|x| x / k as f64).collect()))
            .collect();
        Some(Self { mean, sd, centres })
    }

    /// Squared z-score distance of `v` to each label's centre (infinite for a label without one).
    pub fn distances(&self, v: &[f64]) -> Vec<f64> {
        let z: Vec<f64> = v
            .iter()
            .zip(self.mean.iter().zip(&self.sd))
            .map(|(x, (m, s))| (x - m) / s)
            .collect();
        self.centres
            .iter()
            .map(|c| {
                c.as_ref().map_or(f64::INFINITY, |c| {
                    c.iter().zip(&z).map(|(a, b)| (a - b).powi(2)).sum()
                })
            })
            .collect()
    }

    /// The label of the nearest centre.
    pub fn classify(&self, v: &[f64]) -> usize {
        let d = self.distances(v);
        (0..d.len()).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0)
    }
}

/// Each item judged by a classifier trained on all the others (`(label, vector)`), as a
/// confusion matrix over `labels`, and per item its distances to every centre (for pairwise
/// decisions, [`pairwise_share`]).
pub fn leave_one_out(labels: &[&str], items: &[(usize, Vec<f64>)]) -> (Confusion, Vec<Vec<f64>>) {
    let mut conf = Confusion::new(labels);
    let mut dists = Vec::with_capacity(items.len());
    for (i, (truth, v)) in items.iter().enumerate() {
        let rest = items
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != i)
            .map(|(_, (l, x))| (*l, x.as_slice()));
        let c = NearestCentre::train(labels.len(), rest).expect("at least 3 items");
        let d = c.distances(v);
        let p = (0..d.len()).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
        conf.add(*truth, p);
        dists.push(d);
    }
    (conf, dists)
}

/// Share of the items of labels `a` and `b` that a choice between those two centres alone
/// (the nearer of the two) gives their own label, from [`leave_one_out`]'s distances.
pub fn pairwise_share(items: &[(usize, Vec<f64>)], dists: &[Vec<f64>], a: usize, b: usize) -> f64 {
    let (mut right, mut n) = (0usize, 0usize);
    for ((truth, _), d) in items.iter().zip(dists) {
        let other = match *truth {
            t if t == a => b,
            t if t == b => a,
            _ => continue,
        };
        n += 1;
        right += usize::from(d[*truth] < d[other]);
    }
    right as f64 / n as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two well-separated clusters and one between them: left out one at a time, the separated
    /// ones are recognised, pairwise they are told apart, and the matrix counts every item once.
    #[test]
    fn separated_labels_are_recognised_and_counted() {
        let mut items = Vec::new();
        for i in 0..6 {
            let e = 0.1 * i as f64;
            items.push((0, vec![0.0 + e, 0.0]));
            items.push((1, vec![10.0 + e, 0.0]));
            items.push((2, vec![5.0 + e, 0.0]));
        }
        let (conf, d) = leave_one_out(&["a", "b", "c"], &items);
        assert_eq!(conf.total(), 18);
        assert_eq!(conf.correct(), 18, "{conf:?}");
        assert!((pairwise_share(&items, &d, 0, 1) - 1.0).abs() < 1e-12);
        let md = conf.markdown(|s| s.to_uppercase());
        assert!(md.contains("| A | B | C |") && md.contains("**6**"), "{md}");
        // Identical clusters cannot be told apart better than by chance.
        let same: Vec<(usize, Vec<f64>)> = (0..20).map(|i| (i % 2, vec![(i / 2) as f64])).collect();
        let (_, d) = leave_one_out(&["x", "y"], &same);
        assert!(pairwise_share(&same, &d, 0, 1) < 0.6);
    }
}
