//! Mode extraction: a recording → up to 50 damped sinusoids `10^((a − b·t)/20)·cos(2πft + φ)`
//! (docs/model.md §2, Traer et al. 2019 §2.1 eq. 2). Instead of Traer's iterative spectrogram matching
//! we use a higher-resolution pipeline (compared with that baseline, [`crate::fit::traer`], in
//! docs/presets.md, "Extraction on synthetic ground truth"):
//!
//! 1. DC removal, onset detection (first sample ≥ 10 % of the peak), so t = 0 is the strike.
//! 2. Peak picking on a zero-padded Blackman–Harris FFT of the ringing part (−92 dB side lobes, so
//!    a strong mode's leakage is never taken for a weak mode), parabolic interpolation of the
//!    log magnitude for the frequency.
//! 3. Per mode, a short-time DTFT track evaluated exactly at the mode frequency on the signal
//!    with all *other* modes subtracted; the decay is the slope of a line fitted to the dB track
//!    above the track's noise floor and before any fade-out/gate (points more than 3 dB below the
//!    extrapolated line end the fit).
//! 4. Onset levels and phases by joint linear least squares of all damped sinusoids on the first
//!    part of the signal. Steps 3–4 are iterated.
//! 5. Attack: every mode is multiplied by `1 − e^{−t/τ_a}` with τ_a from [`ATTACK_GRID_S`]
//!    (smallest time-domain residual of the joint fit), t = 0 moved back to the fitted start of
//!    that ramp, each decay refined by variable projection with the attack, and the levels of
//!    the [`MAX_MODES`] kept modes refit on their own (docs/presets.md, "Extraction, per
//!    recording").

use super::lsq::{joint_ls, joint_ls_attack, joint_ls_taus};
use crate::analysis::signal::{decay_span, dtft_track, golden_section_min, onset_and_dc, Mode};
use crate::engine::dsp::DB_PER_NEPER;
use realfft::RealFftPlanner;

/// Most modes extracted (Agarwal et al. use the 50 strongest).
pub const MAX_MODES: usize = 50;
/// Least separation of two extracted modes, in resolution cells (fs/ls_len Hz) of the
/// least-squares span. Why one cell: closer components are beyond the least squares'
/// resolution and come out with large, cancelling amplitudes; keeping them, or merging at two
/// cells, left the recordings' resynthesis distance larger.
const MIN_SEPARATION_CELLS: f64 = 1.0;

/// What the extraction found.
#[derive(Debug, Clone)]
pub struct Extraction {
    /// Modes, strongest first.
    pub modes: Vec<Mode>,
    /// Onset sample index in the input.
    pub onset: usize,
    /// DC offset removed.
    pub dc: f64,
    /// The recording's common attack time constant τ_a in seconds (0: the modes start at full
    /// amplitude), chosen for all modes together before each mode's own [`Mode::attack_s`] is
    /// refined; see [`ATTACK_GRID_S`].
    pub attack_s: f64,
}

/// Attack time constants tried per recording, s. The one whose joint least-squares fit leaves
/// the smallest time-domain residual on the fitting span is kept (a maximum-likelihood choice
/// in white noise, made on the waveform, not on the spectral distance that reports it). Why:
/// struck bars with resonators (marimba) and soft mallets build up over 5–30 ms, and a damped
/// sinusoid that starts at full amplitude has spectral skirts 6–22 dB above such a recording
/// below its fundamental. The 0.125 and 0.25 ms steps are a hard stick's contact time: the
/// recording's onset is never a one-sample step, and a step's 1/f² skirt overfills the weak
/// high bands.
pub const ATTACK_GRID_S: [f64; 11] = [
    0.0, 0.125e-3, 0.25e-3, 0.5e-3, 1e-3, 2e-3, 4e-3, 8e-3, 16e-3, 32e-3, 64e-3,
];

/// Blackman–Harris 4-term window of length n.
fn blackman_harris(n: usize) -> Vec<f64> {
    let (a0, a1, a2, a3) = (0.35875, 0.48829, 0.14128, 0.01168);
    (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / (n.max(2) - 1) as f64;
            a0 - a1 * t.cos() + a2 * (2.0 * t).cos() - a3 * (3.0 * t).cos()
        })
        .collect()
}

/// Extracts up to `max_modes` modes from a mono signal at sample rate `fs`.
pub fn extract(x: &[f64], fs: f64, max_modes: usize) -> Extraction {
    let (onset, dc) = onset_and_dc(x);
    let y: Vec<f64> = x[onset..].iter().map(|v| v - dc).collect();
    let n = y.len();
    let seg = analysis_segment(&y, fs);
    let freqs = candidate_peaks(&y, fs, seg, max_modes);
    if freqs.is_empty() {
        return Extraction {
            modes: Vec::new(),
            onset,
            dc,
            attack_s: 0.0,
        };
    }
    // Least-squares span: long enough to resolve the modes, short enough to avoid most fades.
    let ls_len = n
        .min(((0.5 * fs) as usize).max(seg.min(n)))
        .min((0.6 * n as f64) as usize)
        .max(16.min(n));
    let (freqs, mut decays, amps) = track_and_fit(&y, fs, freqs, ls_len);
    // Attack time: the grid value whose joint fit of the strongest modes leaves the smallest
    // residual; the decay refinement below then fits each mode with that build-up (a pure
    // exponential fitted to a mode that builds up over 8 ms errs by ~20 % in decay).
    let (sf, sd) = strongest(&freqs, &decays, &amps, max_modes);
    let (mut tau0, _) = attack_grid(&y[..ls_len], fs, &sf, &sd);
    // The onset (10 % of the peak) lies partway up a slow build-up: the ramp's start is found
    // as the lead `δ` before the onset whose fit leaves the smallest residual over a common
    // window, and t = 0 moves there. Measured on the synthetic 8 ms build-up
    // (tests/integration/fit_extract.rs `recovers_attack_and_modes_of_a_slow_build_up`, 44.1 kHz): worst
    // decay error 8.7 % with t = 0 at the onset, 4.1 % with t = 0 at the fitted ramp start.
    let lead = ramp_start(x, onset, dc, ls_len, fs, (&sf, &sd), tau0);
    let onset = onset - lead;
    let y: Vec<f64> = x[onset..].iter().map(|v| v - dc).collect();
    if lead > 0 {
        tau0 = attack_grid(&y[..ls_len], fs, &sf, &sd).0;
    }
    let mut amps = amps;
    if tau0 > 0.0 {
        amps = joint_ls_attack(&y[..ls_len], fs, &freqs, &decays, tau0 * fs).0;
    }
    let tau = tau0 * fs;
    refine_decays(&y[..ls_len], fs, &freqs, &mut decays, &mut amps, tau);
    // Keep the `max_modes` strongest of a joint fit over all candidates, then fit the levels
    // and phases of the kept modes alone, once per attack time of the grid. Why refit: the
    // dropped candidates' share of the signal would otherwise be missing from the
    // resynthesis, and the kept modes' levels were fitted next to them.
    let amps = joint_ls_attack(&y[..ls_len], fs, &freqs, &decays, tau).0;
    let (freqs, decays) = strongest(&freqs, &decays, &amps, max_modes);
    let (attack_s, amps) = attack_grid(&y[..ls_len], fs, &freqs, &decays);
    let (taus, amps) = per_mode_attacks(&y[..ls_len], fs, &freqs, &decays, attack_s * fs, amps);
    let mut modes: Vec<Mode> = (0..freqs.len())
        .map(|k| {
            let (a, b) = amps[k];
            Mode {
                freq_hz: freqs[k],
                level_db: 20.0 * a.hypot(b).max(1e-300).log10(),
                decay_db_per_s: decays[k],
                phase: (-b).atan2(a),
                attack_s: taus[k] / fs,
                ring: None,
            }
        })
        .filter(|m| m.level_db.is_finite() && m.level_db > -250.0)
        .collect();
    modes.sort_by(|a, b| b.level_db.total_cmp(&a.level_db));
    Extraction {
        modes,
        onset,
        dc,
        attack_s,
    }
}

/// Samples of `y` (from its onset) the peaks are picked from: until its 10 ms RMS envelope is
/// 45 dB below its peak, within 50 ms..1 s.
fn analysis_segment(y: &[f64], fs: f64) -> usize {
    let n = y.len();
    let hop = ((0.0025 * fs) as usize).max(1);
    let win = ((0.010 * fs) as usize).max(1);
    let mut env = Vec::new();
    let mut i = 0;
    while i + win <= n {
        env.push(y[i..i + win].iter().map(|v| v * v).sum::<f64>() / win as f64);
        i += hop;
    }
    let emax = env.iter().cloned().fold(1e-300, f64::max);
    let seg_end = env
        .iter()
        .rposition(|&e| e > emax * 10f64.powf(-4.5))
        .map(|k| k * hop + win)
        .unwrap_or(n);
    // Why 50 ms..1 s: ≥ 20 Hz resolution for the shortest strikes, ≤ 1 Hz where modes ring.
    seg_end.clamp(((0.05 * fs) as usize).min(n), ((1.0 * fs) as usize).min(n))
}

/// Candidate frequencies: spectral peaks of the first `seg` samples of `y` and of two shorter
/// spans, each new only beyond its span's resolution from those already found, at most
/// `3 × max_modes`. Why several lengths: the long one resolves close, slowly decaying modes;
/// the short ones see fast-decaying modes that a long window's tapered start would hide.
fn candidate_peaks(y: &[f64], fs: f64, seg: usize, max_modes: usize) -> Vec<f64> {
    let mut cands: Vec<(f64, f64, f64)> = Vec::new();
    for len in [
        seg,
        ((0.25 * fs) as usize).min(seg),
        ((0.06 * fs) as usize).min(seg),
    ] {
        if len < 32 {
            continue;
        }
        let res = 4.0 * fs / len as f64;
        for (f, lvl) in pick_peaks(&y[..len], fs, 2 * max_modes) {
            if cands.iter().all(|c| (c.0 - f).abs() > res.max(c.2)) {
                cands.push((f, lvl, res));
            }
        }
    }
    cands.iter().take(3 * max_modes).map(|c| c.0).collect()
}

/// Three passes of: each candidate's decay and frequency from the DTFT track of the residual
/// plus its own mode, candidates closer than [`MIN_SEPARATION_CELLS`] dropped, the amplitudes
/// fitted jointly on the first `ls_len` samples; after the first pass, modes the joint fit
/// gives almost nothing are dropped. Returns frequencies, decays and amplitudes.
#[allow(clippy::type_complexity)]
fn track_and_fit(
    y: &[f64],
    fs: f64,
    mut freqs: Vec<f64>,
    ls_len: usize,
) -> (Vec<f64>, Vec<f64>, Vec<(f64, f64)>) {
    let n = y.len();
    let mut decays: Vec<f64> = freqs.iter().map(|_| 20.0).collect();
    let mut amps = vec![(0.0, 0.0); freqs.len()];
    let mut model = vec![0.0; n];
    for pass in 0..3 {
        // Decay per mode from the DTFT track of (residual + own mode).
        for k in 0..freqs.len() {
            let own = mode_signal(freqs[k], decays[k], amps[k], fs, n);
            let target: Vec<f64> = if pass == 0 {
                y.to_vec()
            } else {
                (0..n).map(|i| y[i] - model[i] + own[i]).collect()
            };
            if let Some((d, df)) = track_decay(&target, fs, freqs[k], n) {
                decays[k] = d;
                freqs[k] += df;
            }
        }
        // Candidates the tracking moved within one resolution cell of the least-squares span
        // (fs/ls_len Hz) of a stronger-picked one are dropped: the joint fit cannot tell them
        // apart and gave such groups (up to 11 copies within 0.7 Hz on the marimbas) levels of
        // +30…+50 dB that cancel inside the span and not after it, spending the mode budget on
        // one peak (docs/fit-alternatives.md).
        let min_sep = MIN_SEPARATION_CELLS * fs / ls_len as f64;
        let mut keep = vec![true; freqs.len()];
        for a in 0..freqs.len() {
            if keep[a] {
                for b in a + 1..freqs.len() {
                    if (freqs[a] - freqs[b]).abs() < min_sep {
                        keep[b] = false;
                    }
                }
            }
        }
        retain_where(&keep, &mut freqs, &mut decays, &mut amps);
        amps = joint_ls(&y[..ls_len], fs, &freqs, &decays);
        model = vec![0.0; n];
        for k in 0..freqs.len() {
            let s = mode_signal(freqs[k], decays[k], amps[k], fs, n);
            for i in 0..n {
                model[i] += s[i];
            }
        }
        // Drop modes the joint fit gives (almost) nothing: leakage of a neighbour.
        if pass == 0 {
            let amax = amps.iter().map(|a| a.0.hypot(a.1)).fold(0.0, f64::max);
            let keep: Vec<bool> = amps.iter().map(|a| a.0.hypot(a.1) > amax * 1e-4).collect();
            retain_where(&keep, &mut freqs, &mut decays, &mut amps);
        }
    }
    (freqs, decays, amps)
}

/// Variable-projection refinement of each decay on the least-squares span `y` (the others
/// fixed), with the build-up `tau` (samples): the time-domain residual is the
/// maximum-likelihood criterion in white noise and uses the weak, fast modes' few milliseconds
/// that the STFT track hardly resolves. Updates `decays` and `amps` in place.
fn refine_decays(y: &[f64], fs: f64, freqs: &[f64], decays: &mut [f64], amps: &mut [(f64, f64)], tau: f64) {
    let ls_len = y.len();
    let mut r = residual(y, fs, freqs, decays, amps, &vec![tau; freqs.len()]);
    for k in 0..freqs.len() {
        let own = mode_signal_attack(freqs[k], decays[k], amps[k], tau, fs, ls_len);
        let target: Vec<f64> = (0..ls_len).map(|i| r[i] + own[i]).collect();
        let cost = |ln_d: f64| -> (f64, (f64, f64)) {
            let (a, e) = joint_ls_attack(&target, fs, &freqs[k..=k], &[ln_d.exp()], tau);
            (e, a[0])
        };
        // Why 1/8..8x: a failed DTFT track leaves the 20 dB/s start value; 0.5..2x could not
        // reach the true decay of short-lived modes.
        let ln_d = golden_section_min((0.125 * decays[k]).ln(), (8.0 * decays[k]).ln(), |x| cost(x).0);
        let (_, a) = cost(ln_d);
        decays[k] = ln_d.exp();
        amps[k] = a;
        let s = mode_signal_attack(freqs[k], decays[k], a, tau, fs, ls_len);
        for i in 0..ls_len {
            r[i] = target[i] - s[i];
        }
    }
}

/// Keeps the candidates whose `keep` is set, in order, in the three parallel lists.
fn retain_where(keep: &[bool], freqs: &mut Vec<f64>, decays: &mut Vec<f64>, amps: &mut Vec<(f64, f64)>) {
    let mut j = 0;
    for k in 0..freqs.len() {
        if keep[k] {
            freqs[j] = freqs[k];
            decays[j] = decays[k];
            amps[j] = amps[k];
            j += 1;
        }
    }
    freqs.truncate(j);
    decays.truncate(j);
    amps.truncate(j);
}

/// Each mode's own attack time: coordinate descent over the modes (two rounds), each mode's
/// τ chosen from [`ATTACK_GRID_S`] by the smallest residual of its own least-squares fit on the
/// residual of all the others, then one joint fit of all levels and phases with those τ's. Why:
/// one τ per recording is a compromise between modes that build up (a bar's fundamental under
/// its resonator) and modes the strike sets ringing at once (docs/presets.md, resynthesis
/// distance). Starts from the common `tau` (samples) and its amplitudes `amps`; returns the τ's
/// (samples) and the final amplitudes.
fn per_mode_attacks(
    y: &[f64],
    fs: f64,
    freqs: &[f64],
    decays: &[f64],
    tau: f64,
    mut amps: Vec<(f64, f64)>,
) -> (Vec<f64>, Vec<(f64, f64)>) {
    let n = y.len();
    let mut taus = vec![tau; freqs.len()];
    let mut r = residual(y, fs, freqs, decays, &amps, &taus);
    for _ in 0..2 {
        for k in 0..freqs.len() {
            let own = mode_signal_attack(freqs[k], decays[k], amps[k], taus[k], fs, n);
            let target: Vec<f64> = (0..n).map(|i| r[i] + own[i]).collect();
            let mut best = (f64::INFINITY, taus[k], amps[k]);
            for &t in &ATTACK_GRID_S {
                let (a, e) = joint_ls_taus(&target, fs, &freqs[k..=k], &decays[k..=k], &[t * fs]);
                if e < best.0 {
                    best = (e, t * fs, a[0]);
                }
            }
            (taus[k], amps[k]) = (best.1, best.2);
            let s = mode_signal_attack(freqs[k], decays[k], amps[k], taus[k], fs, n);
            for i in 0..n {
                r[i] = target[i] - s[i];
            }
        }
    }
    let amps = joint_ls_taus(y, fs, freqs, decays, &taus).0;
    (taus, amps)
}

/// `y` minus the modes (amplitudes `amps`, attack τ's `taus` in samples).
fn residual(
    y: &[f64],
    fs: f64,
    freqs: &[f64],
    decays: &[f64],
    amps: &[(f64, f64)],
    taus: &[f64],
) -> Vec<f64> {
    let mut r = y.to_vec();
    for k in 0..freqs.len() {
        let s = mode_signal_attack(freqs[k], decays[k], amps[k], taus[k], fs, y.len());
        for (ri, si) in r.iter_mut().zip(&s) {
            *ri -= si;
        }
    }
    r
}

/// Frequencies and decays of the `max` candidates with the largest fitted amplitude (and a
/// finite level above −250 dB), strongest first.
fn strongest(freqs: &[f64], decays: &[f64], amps: &[(f64, f64)], max: usize) -> (Vec<f64>, Vec<f64>) {
    let mag = |k: usize| amps[k].0.hypot(amps[k].1);
    let mut keep: Vec<usize> = (0..freqs.len())
        .filter(|&k| {
            let l = 20.0 * mag(k).max(1e-300).log10();
            l.is_finite() && l > -250.0
        })
        .collect();
    keep.sort_by(|&i, &j| mag(j).total_cmp(&mag(i)));
    keep.truncate(max);
    keep.iter().map(|&k| (freqs[k], decays[k])).unzip()
}

/// Samples between the start of the attack ramp and the detected `onset` (0 without an attack):
/// golden-section search over `[0, min(onset, τ/2)]` for the lead whose joint fit of `modes`
/// (frequencies, decays) with attack τ (s) leaves the smallest residual over the common window
/// `[onset − max lead, onset + len)` (the samples before a candidate's start count as residual).
fn ramp_start(
    x: &[f64],
    onset: usize,
    dc: f64,
    len: usize,
    fs: f64,
    (freqs, decays): (&[f64], &[f64]),
    tau_s: f64,
) -> usize {
    let max_lead = onset.min((0.5 * tau_s * fs) as usize);
    if max_lead == 0 {
        return 0;
    }
    let mut cache: Vec<Option<f64>> = vec![None; max_lead + 1];
    let mut cost = |lead: usize| -> f64 {
        if let Some(c) = cache[lead] {
            return c;
        }
        let start = onset - lead;
        let y: Vec<f64> = x[start..(onset + len).min(x.len())]
            .iter()
            .map(|v| v - dc)
            .collect();
        let pre: f64 = x[onset - max_lead..start]
            .iter()
            .map(|v| (v - dc) * (v - dc))
            .sum();
        let c = joint_ls_attack(&y, fs, freqs, decays, tau_s * fs).1 + pre;
        cache[lead] = Some(c);
        c
    };
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (0.0f64, max_lead as f64);
    while hi - lo > 1.0 {
        let (x1, x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if cost(x1.round() as usize) <= cost(x2.round() as usize) {
            hi = x2;
        } else {
            lo = x1;
        }
    }
    let (a, b) = (lo.floor() as usize, (hi.ceil() as usize).min(max_lead));
    (a..=b).min_by(|&i, &j| cost(i).total_cmp(&cost(j))).unwrap_or(0)
}

/// Joint least-squares fit of the modes (`freqs`, `decays`) once per [`ATTACK_GRID_S`] value;
/// returns the attack time (s) with the smallest residual and that fit's amplitudes.
fn attack_grid(y: &[f64], fs: f64, freqs: &[f64], decays: &[f64]) -> (f64, Vec<(f64, f64)>) {
    let mut best = (f64::INFINITY, 0.0, Vec::new());
    for &tau in &ATTACK_GRID_S {
        let (a, r) = joint_ls_attack(y, fs, freqs, decays, tau * fs);
        if r < best.0 {
            best = (r, tau, a);
        }
    }
    (best.1, best.2)
}

/// Damped sinusoid `e^{−dt}(A cos ωt + B sin ωt)` for `n` samples.
fn mode_signal(f: f64, decay_db: f64, ab: (f64, f64), fs: f64, n: usize) -> Vec<f64> {
    mode_signal_attack(f, decay_db, ab, 0.0, fs, n)
}

/// As [`mode_signal`] times the attack `1 − e^{−i/τ}` (τ in samples; 0: none).
fn mode_signal_attack(f: f64, decay_db: f64, (a, b): (f64, f64), tau: f64, fs: f64, n: usize) -> Vec<f64> {
    let w = std::f64::consts::TAU * f / fs;
    let d = decay_db / DB_PER_NEPER / fs;
    let (mut pr, mut pi) = (1.0f64, 0.0f64);
    let (cr, ci) = ((-d).exp() * w.cos(), (-d).exp() * w.sin());
    let mut out = vec![0.0; n];
    for v in out.iter_mut() {
        *v = a * pr + b * pi;
        let t = pr * cr - pi * ci;
        pi = pr * ci + pi * cr;
        pr = t;
    }
    if tau > 0.0 {
        let q = (-1.0 / tau).exp();
        let mut g = 1.0;
        for v in out.iter_mut() {
            *v *= 1.0 - g;
            g *= q;
        }
    }
    out
}

/// Synthesises modes (as extracted, levels in dB re full scale, each with its own
/// [`Mode::attack_s`]) for `n` samples.
pub fn synthesize(modes: &[Mode], fs: f64, n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n];
    for m in modes {
        let amp = 10f64.powf(m.level_db / 20.0);
        // A ring is a second stage at the same frequency and phase (docs/model.md "Ring").
        let stages = match m.ring {
            Some(r) => [(1.0 - r.share, m.decay_db_per_s), (r.share, r.decay_db_per_s)],
            None => [(1.0, m.decay_db_per_s), (0.0, 0.0)],
        };
        for (share, decay) in stages.into_iter().filter(|s| s.0 > 0.0) {
            let a = share * amp;
            let s = mode_signal_attack(
                m.freq_hz,
                decay,
                (a * m.phase.cos(), -a * m.phase.sin()),
                m.attack_s * fs,
                fs,
                n,
            );
            for i in 0..n {
                out[i] += s[i];
            }
        }
    }
    out
}

/// Peak frequencies of the zero-padded Blackman–Harris spectrum, strongest first.
fn pick_peaks(y: &[f64], fs: f64, max: usize) -> Vec<(f64, f64)> {
    let n = y.len();
    let w = blackman_harris(n);
    // Why ×8 zero padding: parabolic interpolation of the log magnitude is then biased by
    // < 0.001 bin, far below the 0.1 % frequency target.
    let nfft = (8 * n).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let mut buf = vec![0.0; nfft];
    for i in 0..n {
        buf[i] = y[i] * w[i];
    }
    let mut spec = fft.make_output_vec();
    fft.process(&mut buf, &mut spec).expect("fft sizes match");
    let mag: Vec<f64> = spec
        .iter()
        .map(|c| 10.0 * (c.norm_sqr() + 1e-300).log10())
        .collect();
    let bin_hz = fs / nfft as f64;
    // Half main-lobe width of Blackman–Harris: 4 unpadded bins.
    let half = ((4.0 * nfft as f64 / n as f64) as usize).max(2);
    let lo = ((20.0 / bin_hz) as usize).max(1);
    let hi = ((0.49 * fs / bin_hz) as usize).min(mag.len() - 2);
    if hi <= lo + 2 {
        return Vec::new();
    }
    let mut sorted: Vec<f64> = mag[lo..hi].to_vec();
    sorted.sort_by(f64::total_cmp);
    let floor = sorted[sorted.len() / 2];
    let top = sorted[sorted.len() - 1];
    // Why +12 dB over the median and within 90 dB of the top: the median of a ringing spectrum is
    // the noise/leakage level; 12 dB above it a peak is a mode, not a noise fluctuation.
    let thresh = (floor + 12.0).max(top - 90.0);
    let mut peaks: Vec<(f64, f64)> = Vec::new();
    for k in lo..hi {
        let v = mag[k];
        if v < thresh || v < mag[k - 1] || v < mag[k + 1] {
            continue;
        }
        let a = k.saturating_sub(half).max(lo);
        let b = (k + half).min(hi);
        if mag[a..=b].iter().any(|&u| u > v) {
            continue;
        }
        let (m1, m0, p1) = (mag[k - 1], v, mag[k + 1]);
        let den = m1 - 2.0 * m0 + p1;
        let delta = if den.abs() > 1e-12 {
            0.5 * (m1 - p1) / den
        } else {
            0.0
        };
        peaks.push(((k as f64 + delta.clamp(-0.5, 0.5)) * bin_hz, v));
    }
    peaks.sort_by(|a, b| b.1.total_cmp(&a.1));
    peaks.truncate(max);
    peaks
}

/// Decay (dB/s) of the component at `f` from a short-time DTFT track of `y`, and a frequency
/// correction (Hz) from the phase advance between frames over the fitted span.
fn track_decay(y: &[f64], fs: f64, f: f64, n: usize) -> Option<(f64, f64)> {
    // Why ~40 ms frames (power of two near it): separates modes ≥ ~50 Hz apart while giving
    // ≥ 25 points per second of decay; the other modes are subtracted anyway.
    let nw = ((0.04 * fs) as usize).next_power_of_two().min(n / 2).max(32);
    if n < 2 * nw {
        return None;
    }
    let hop = nw / 4;
    let (t, power, ph) = dtft_track(&y[..n], fs, f, nw, hop);
    let l: Vec<f64> = power.iter().map(|p| 10.0 * (p + 1e-300).log10()).collect();
    let (decay, k0, stop) = decay_span(&t, &l)?;
    let (mut num, mut den) = (0.0, 0.0);
    for k in k0..stop {
        let d = (ph[k + 1] - ph[k] + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        let wgt = 10f64.powf(l[k] / 20.0);
        num += wgt * d;
        den += wgt;
    }
    let df = if den > 0.0 {
        num / den / hop as f64 * fs / std::f64::consts::TAU
    } else {
        0.0
    };
    Some((decay, df))
}
