//! The signal primitives the fit and the evaluation share: a mode (damped sinusoid) and its
//! energy, a strike's onset, the short-time DTFT track of one frequency and the decay read off
//! it, and the line and golden-section fits they use.

/// One mode: a damped sinusoid with an optional build-up, as extracted from a recording
/// ([`crate::fit::recording::extract`]), tracked as a partial ([`super::partials`]) or pooled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode {
    /// Frequency in Hz.
    pub freq_hz: f64,
    /// Onset level in dB re full scale (amplitude of the damped cosine at the onset).
    pub level_db: f64,
    /// Decay in dB/s.
    pub decay_db_per_s: f64,
    /// Phase at the onset, radians.
    pub phase: f64,
    /// Build-up time constant τ, s: the mode is multiplied by `1 − e^{−t/τ}` (0: it starts at
    /// full amplitude). See [`crate::fit::recording::extract::ATTACK_GRID_S`].
    pub attack_s: f64,
    /// The mode's second, slower stage after its knock, if it has one ([`Ring`]).
    pub ring: Option<Ring>,
}

/// A mode's second, slower stage (docs/model.md "Ring"): the mode sounds
/// `g·((1 − s)·e^{−σt} + s·e^{−σ_r t})·cos(ωt + φ)`, its knock at the mode's own decay `σ` and
/// the ring at `decay_db_per_s` (`σ_r`), with the amplitude share `s` at the onset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ring {
    /// Amplitude share `s` of the ring at the onset, in (0, 1).
    pub share: f64,
    /// The ring's decay, dB/s, slower than the mode's own.
    pub decay_db_per_s: f64,
}

/// Periodic-offset Hann window of length n (samples at i + ½), shared by the short-time
/// analyses.
pub(crate) fn hann(n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * (i as f64 + 0.5) / n as f64).cos())
        .collect()
}

/// DC offset estimate and onset index.
pub fn onset_and_dc(x: &[f64]) -> (usize, f64) {
    let dc = x.iter().sum::<f64>() / x.len().max(1) as f64;
    let peak = x.iter().fold(0.0f64, |m, v| m.max((v - dc).abs()));
    // Why 10 %: the first cycle of a strike reaches the peak within a few ms; 10 % is far above
    // any noise floor (≥ 20 dB) and at most a fraction of a millisecond before the true onset.
    let onset = x.iter().position(|v| (v - dc).abs() >= 0.1 * peak).unwrap_or(0);
    (onset, dc)
}

/// `x` from its onset, DC removed ([`onset_and_dc`]): the signal every measurement of a
/// strike starts from.
pub fn from_onset(x: &[f64]) -> Vec<f64> {
    let (onset, dc) = onset_and_dc(x);
    x.get(onset..)
        .unwrap_or_default()
        .iter()
        .map(|v| v - dc)
        .collect()
}

/// Short-time DTFT of `y` evaluated exactly at `f` Hz: Hann frames of `nw` samples every `hop`.
/// Returns per frame its centre time (s), its power `|X|²` and its phase relative to a global
/// reference `e^{iωs}` (so it advances by the frequency error × hop per frame).
pub(crate) fn dtft_track(
    y: &[f64],
    fs: f64,
    f: f64,
    nw: usize,
    hop: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let w = hann(nw);
    let om = std::f64::consts::TAU * f / fs;
    let (c, s) = (om.cos(), om.sin());
    let (mut t, mut power, mut ph) = (Vec::new(), Vec::new(), Vec::new());
    let mut start = 0;
    while start + nw <= y.len() {
        let (mut pr, mut pi) = (1.0f64, 0.0f64);
        let (mut re, mut im) = (0.0, 0.0);
        for i in 0..nw {
            let v = y[start + i] * w[i];
            re += v * pr;
            im -= v * pi;
            let tt = pr * c - pi * s;
            pi = pr * s + pi * c;
            pr = tt;
        }
        t.push((start as f64 + 0.5 * nw as f64) / fs);
        power.push(re * re + im * im);
        ph.push(im.atan2(re) - (om * start as f64).rem_euclid(std::f64::consts::TAU));
        start += hop;
    }
    (t, power, ph)
}

/// Minimum of a unimodal `cost` over `[lo, hi]` by 40 golden-section steps; returns the final
/// bracket's midpoint.
pub(crate) fn golden_section_min(mut lo: f64, mut hi: f64, mut cost: impl FnMut(f64) -> f64) -> f64 {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    for _ in 0..40 {
        if f1 < f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = cost(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = cost(x2);
        }
    }
    0.5 * (lo + hi)
}

/// Line fit of a dB track above its noise floor and before a fade; returns −slope in dB/s.
pub fn decay_from_track(t: &[f64], l: &[f64]) -> Option<f64> {
    decay_span(t, l).map(|v| v.0)
}

/// Decay and the index span `k0..=stop` of the track it was fitted on.
pub fn decay_span(t: &[f64], l: &[f64]) -> Option<(f64, usize, usize)> {
    if t.len() < 3 {
        return None;
    }
    let mut sorted = l.to_vec();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 20];
    let top = sorted[sorted.len() - 1];
    // Start at the track maximum (the first frames still contain the strike's rise).
    let k0 = l.iter().position(|&v| v == top).unwrap_or(0);
    // Why 5th percentile + 16 dB: a noise-only DTFT track fluctuates (Rayleigh) with its 5th
    // percentile ~10 dB under its mean; 6 dB more above the mean noise level the noise shifts
    // the mode's dB level by < 1 dB, closer the track flattens and the decay is underestimated.
    let usable_floor = floor + 16.0;
    let mut end = k0;
    while end + 1 < l.len() && l[end + 1] > usable_floor {
        end += 1;
    }
    if end < k0 + 2 {
        // Too short above the floor: use the first three points.
        end = (k0 + 2).min(l.len() - 1);
        if end < k0 + 2 {
            return None;
        }
    }
    // Initial fit on the first half, then extend while points stay within 3 dB of the line
    // (a gate or fade-out bends the track down).
    let mut stop = (k0 + (end - k0) / 2).max(k0 + 2);
    for _ in 0..3 {
        let (slope, icpt) = line_fit(&t[k0..=stop], &l[k0..=stop]);
        let mut new_stop = stop;
        let mut misses = 0;
        for k in (k0 + 1)..=end {
            if l[k] < slope * t[k] + icpt - 2.0 {
                misses += 1;
                if misses >= 2 {
                    break;
                }
            } else {
                misses = 0;
                new_stop = k;
            }
        }
        if new_stop == stop {
            break;
        }
        stop = new_stop.max(k0 + 2);
    }
    // A gate bends the track already in the frames whose window overlaps its start: drop the
    // last window length (4 hops) when the span ended early, i.e. at a fade, not at the floor.
    if stop < end && stop >= k0 + 6 {
        stop -= 4;
    }
    let (slope, _) = line_fit(&t[k0..=stop], &l[k0..=stop]);
    Some(((-slope).max(0.05), k0, stop))
}

/// Least-squares line `l ≈ slope·t + intercept`; returns `(slope, intercept)`.
pub(crate) fn line_fit(t: &[f64], l: &[f64]) -> (f64, f64) {
    let n = t.len() as f64;
    let mt = t.iter().sum::<f64>() / n;
    let ml = l.iter().sum::<f64>() / n;
    let mut sxy = 0.0;
    let mut sxx = 0.0;
    for i in 0..t.len() {
        sxy += (t[i] - mt) * (l[i] - ml);
        sxx += (t[i] - mt) * (t[i] - mt);
    }
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (slope, ml - slope * mt)
}

/// A mode's energy in dB (up to a constant): onset level minus 10·log10 of the decay rate,
/// and with a [`Ring`] its two stages' energy together ([`two_stage_energy`]).
pub fn energy_db(m: &Mode) -> f64 {
    let k = m.decay_db_per_s.max(1e-3);
    let stages = match m.ring {
        Some(r) => two_stage_energy(r.share, k, r.decay_db_per_s.max(1e-3)),
        None => 1.0,
    };
    m.level_db - 10.0 * k.log10() + 10.0 * stages.log10()
}

/// `∫ ((1 − s)·e^{−σt} + s·e^{−σ_r t})² dt` re `∫ e^{−2σt} dt`: how much more energy a mode
/// of decay σ carries with a ring of share `s` decaying at σ_r (both positive, in one unit).
pub fn two_stage_energy(share: f64, sigma: f64, sigma_ring: f64) -> f64 {
    let (s, k, q) = (share, sigma, sigma_ring);
    (1.0 - s).powi(2) + 4.0 * s * (1.0 - s) * k / (k + q) + s * s * k / q
}
