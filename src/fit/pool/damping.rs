//! Damping-law fit (Sterling et al. 2019 §1.2, docs/model.md §4): per-mode damping
//! `c_i = α1 + α2·ω_i^(2α3) + N(0, σ²) + Exp(η)` fitted by maximum likelihood of the
//! exponentially modified Gaussian (EMG), with ordinary least squares and a strict lower bound
//! (lower convex hull) as baselines. The EMG log-density uses a scaled complementary error
//! function so that it never under/overflows; the optimiser is Nelder–Mead on normalised,
//! log-transformed parameters (all positive).

/// A fitted damping law (α3 = 1 for Rayleigh), σ and η of the EMG (0 for the baselines).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DampingFit {
    /// α1 in 1/s.
    pub alpha1: f64,
    /// α2 in s^(2α3−1).
    pub alpha2: f64,
    /// α3.
    pub alpha3: f64,
    /// Gaussian σ (1/s).
    pub sigma: f64,
    /// Exponential rate η (s), mean outlier 1/η.
    pub eta: f64,
}

impl DampingFit {
    /// `c(ω)`.
    pub fn c(&self, omega: f64) -> f64 {
        self.alpha1 + self.alpha2 * omega.powf(2.0 * self.alpha3)
    }
}

/// `ln erfc(x)` for all real x without overflow (erfcx form for x ≥ 0; Numerical Recipes'
/// Chebyshev-like fit, relative error < 1.2e-7, ample for a likelihood).
pub fn ln_erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    // ln(erfcx(z)) = ln t + poly(t) for z ≥ 0.
    let poly = -1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398 + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    let ln_erfc_z = t.ln() + poly - z * z;
    if x >= 0.0 {
        ln_erfc_z
    } else {
        (2.0 - ln_erfc_z.exp()).ln()
    }
}

/// EMG log-likelihood of residual `r = c_i − μ_i` (docs/model.md §4 density).
fn emg_ll(r: f64, sigma: f64, eta: f64) -> f64 {
    let s = (eta * sigma * sigma - r) / (std::f64::consts::SQRT_2 * sigma);
    (eta / 2.0).ln() + (eta / 2.0) * (eta * sigma * sigma - 2.0 * r) + ln_erfc(s)
}

/// Nelder–Mead minimisation of `f` from `x0`, the initial simplex one `step[i]` along each axis;
/// at most `iters` iterations, stopping early once the simplex's values spread less than
/// `tol·(1 + |best|)` (0: never). Used by the EMG fit here and by `fit::traer`.
pub fn nelder_mead(
    f: &mut dyn FnMut(&[f64]) -> f64,
    x0: &[f64],
    step: &[f64],
    iters: usize,
    tol: f64,
) -> Vec<f64> {
    let n = x0.len();
    let mut pts: Vec<Vec<f64>> = vec![x0.to_vec()];
    for i in 0..n {
        let mut p = x0.to_vec();
        p[i] += step[i];
        pts.push(p);
    }
    let mut vals: Vec<f64> = pts.iter().map(|p| f(p)).collect();
    for _ in 0..iters {
        let mut idx: Vec<usize> = (0..=n).collect();
        idx.sort_by(|&a, &b| vals[a].total_cmp(&vals[b]));
        pts = idx.iter().map(|&i| pts[i].clone()).collect();
        vals = idx.iter().map(|&i| vals[i]).collect();
        if (vals[n] - vals[0]).abs() < tol * (1.0 + vals[0].abs()) {
            break;
        }
        let cen: Vec<f64> = (0..n)
            .map(|j| pts[..n].iter().map(|p| p[j]).sum::<f64>() / n as f64)
            .collect();
        let at = |t: f64| -> Vec<f64> { (0..n).map(|j| cen[j] + t * (pts[n][j] - cen[j])).collect() };
        let xr = at(-1.0);
        let fr = f(&xr);
        if fr < vals[0] {
            let xe = at(-2.0);
            let fe = f(&xe);
            if fe < fr {
                pts[n] = xe;
                vals[n] = fe;
            } else {
                pts[n] = xr;
                vals[n] = fr;
            }
        } else if fr < vals[n - 1] {
            pts[n] = xr;
            vals[n] = fr;
        } else {
            let xc = if fr < vals[n] { at(-0.5) } else { at(0.5) };
            let fc = f(&xc);
            if fc < vals[n].min(fr) {
                pts[n] = xc;
                vals[n] = fc;
            } else {
                for i in 1..=n {
                    pts[i] = (0..n)
                        .map(|j| pts[0][j] + 0.5 * (pts[i][j] - pts[0][j]))
                        .collect();
                    vals[i] = f(&pts[i]);
                }
            }
        }
    }
    let best = (0..=n).min_by(|&a, &b| vals[a].total_cmp(&vals[b])).unwrap_or(0);
    pts[best].clone()
}

/// Ordinary least-squares Rayleigh fit `c = α1 + α2·ω²` (α's clamped at ≥ 0).
pub fn fit_least_squares(omega: &[f64], c: &[f64]) -> DampingFit {
    let lam: Vec<f64> = omega.iter().map(|w| w * w).collect();
    let n = lam.len() as f64;
    let ml = lam.iter().sum::<f64>() / n;
    let mc = c.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for i in 0..lam.len() {
        sxy += (lam[i] - ml) * (c[i] - mc);
        sxx += (lam[i] - ml).powi(2);
    }
    let a2 = if sxx > 0.0 { (sxy / sxx).max(0.0) } else { 0.0 };
    DampingFit {
        alpha1: (mc - a2 * ml).max(0.0),
        alpha2: a2,
        alpha3: 1.0,
        sigma: 0.0,
        eta: 0.0,
    }
}

/// Strict lower bound: the Rayleigh line below every point minimising the total gap (an edge
/// of the lower convex hull of (λ, c), or a flat line at the minimum).
pub fn fit_lower_bound(omega: &[f64], c: &[f64]) -> DampingFit {
    let mut pts: Vec<(f64, f64)> = omega.iter().zip(c).map(|(w, c)| (w * w, *c)).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let mut hull: Vec<(f64, f64)> = Vec::new();
    for p in &pts {
        while hull.len() >= 2 {
            let (a, b) = (hull[hull.len() - 2], hull[hull.len() - 1]);
            if (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0) <= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(*p);
    }
    let cmin = c.iter().cloned().fold(f64::INFINITY, f64::min);
    let gap = |a1: f64, a2: f64| pts.iter().map(|p| p.1 - a1 - a2 * p.0).sum::<f64>();
    let mut best = (cmin.max(0.0), 0.0, gap(cmin.max(0.0), 0.0));
    for w in hull.windows(2) {
        let slope = (w[1].1 - w[0].1) / (w[1].0 - w[0].0);
        if !(slope > 0.0) || !slope.is_finite() {
            continue;
        }
        let a1 = w[0].1 - slope * w[0].0;
        if a1 < 0.0 {
            continue;
        }
        let g = gap(a1, slope);
        if g < best.2 {
            best = (a1, slope, g);
        }
    }
    DampingFit {
        alpha1: best.0,
        alpha2: best.1,
        alpha3: 1.0,
        sigma: 0.0,
        eta: 0.0,
    }
}

/// EMG maximum-likelihood fit; `hybrid` also fits α3 (else α3 = 1, Rayleigh).
/// `omega` in rad/s, `c` in 1/s. Needs ≥ 4 points.
pub fn fit_emg(omega: &[f64], c: &[f64], hybrid: bool) -> Option<DampingFit> {
    if omega.len() < 4 || omega.len() != c.len() {
        return None;
    }
    // Normalise: ω by its median, c by its median, so every parameter is O(1) (Sterling fits
    // on normalised data for the same reason).
    let med = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    };
    let w0 = med(omega).max(1e-9);
    let c0 = med(c).max(1e-9);
    let x: Vec<f64> = omega.iter().map(|w| w / w0).collect();
    let y: Vec<f64> = c.iter().map(|v| v / c0).collect();
    let ls = fit_least_squares(&x, &y);
    let lb = fit_lower_bound(&x, &y);
    let resid_sd = {
        let r: Vec<f64> = x
            .iter()
            .zip(&y)
            .map(|(x, y)| y - lb.alpha1 - lb.alpha2 * x * x)
            .collect();
        let m = r.iter().sum::<f64>() / r.len() as f64;
        (r.iter().map(|v| (v - m).powi(2)).sum::<f64>() / r.len() as f64)
            .sqrt()
            .max(1e-3)
    };
    let a1_0 = (0.5 * (ls.alpha1 + lb.alpha1)).max(1e-3);
    let a2_0 = (0.5 * (ls.alpha2 + lb.alpha2)).max(1e-3);
    let unpack = |p: &[f64]| -> (f64, f64, f64, f64, f64) {
        let a3 = if hybrid { 1.0 + 0.5 * p[4].tanh() } else { 1.0 };
        (p[0].exp(), p[1].exp(), a3, p[2].exp(), p[3].exp())
    };
    let mut nll = |p: &[f64]| -> f64 {
        let (a1, a2, a3, s, e) = unpack(p);
        let mut sum = 0.0;
        for i in 0..x.len() {
            let mu = a1 + a2 * x[i].powf(2.0 * a3);
            sum -= emg_ll(y[i] - mu, s, e);
        }
        if sum.is_finite() {
            sum
        } else {
            1e300
        }
    };
    let mut p0 = vec![a1_0.ln(), a2_0.ln(), (0.5 * resid_sd).ln(), (1.0 / resid_sd).ln()];
    if hybrid {
        p0.push(0.0);
    }
    let mut p = p0;
    for _ in 0..4 {
        p = nelder_mead(&mut nll, &p, &[0.3; 5][..p.len()], 4000, 1e-12);
    }
    let (a1, a2, a3, s, e) = unpack(&p);
    // Back to physical units: c = c0·(a1 + a2·(ω/w0)^(2α3)).
    Some(DampingFit {
        alpha1: c0 * a1,
        alpha2: c0 * a2 / w0.powf(2.0 * a3),
        alpha3: a3,
        sigma: c0 * s,
        eta: e / c0,
    })
}
