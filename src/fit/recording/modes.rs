//! What of an extraction counts as a mode of the object: near-coincident copies merged into one
//! (by the energy of their summed signal), components faster than a one-ERB noise band can ring
//! set apart as strike noise, and the thresholds both use (docs/model.md §3, "What is not a mode").

use crate::analysis::signal::{energy_db, Mode};
use crate::engine::dsp::DB_PER_NEPER;

/// Consolidates modes closer than `rel_sep` × frequency into one, for pooling into presets and
/// for features (not for resynthesis). Why: the joint least-squares fit often splits one
/// recorded mode into near-coincident copies with large, partly cancelling amplitudes (measured:
/// six copies of a marimba's 262 Hz mode at +50…+58 dBFS, whose sum is −9 dBFS), which models
/// a non-exponential envelope well but makes each copy's level meaningless. The merged mode has
/// the amplitude-weighted mean frequency and decay, and the level of a single damped sinusoid
/// with the same energy as the group's summed signal:
/// `E = ½·Σ_jk Re[c_j c_k* / (α_j + α_k − i(ω_j − ω_k))]`, `|A|² = 4αE` (α in 1/s, c the complex
/// onset amplitudes). Result sorted strongest (by energy) first.
pub fn consolidate(modes: &[Mode], rel_sep: f64) -> Vec<Mode> {
    merge_groups(modes, rel_sep, false)
}

/// As [`consolidate`], but each group becomes ONE mode `A·e^{−σt}·(1 − e^{−t/τ})` (the preset
/// format's build-up, docs/model.md "Build-up") that keeps the group's energy and the shape of
/// its envelope, both taken from the components including their own build-ups
/// ([`Mode::attack_s`]). Why: the extractor models a swelling partial (steel drums: τ up to
/// 64 ms) by build-ups and near-coincident cancelling copies; a single attack-free exponential
/// with the group's energy either starts at full level where the recording swelled (attack
/// share up by 0.09–0.15 on the steel pans) or, keeping the energy's mean time, rings as long as
/// the weak slow tail (T60 ×2–8), and no attack-free exponential holds both
/// (docs/fit-alternatives.md). A component of a marimba fitted at +14 dB,
/// 5700 dB/s with a 64 ms build-up carries 34 dB less energy than the same component without
/// it: played without the build-up it is a click the recording does not have.
///
/// σ and τ are the least-squares fit of the model to the group's summed amplitude envelope
/// ([`fit_build_up`]); A then gives the model the group's energy. A group in which no component
/// builds up merges as before build-ups were stored: τ = 0 and the attack-free mode with the
/// group's energy and its energy's mean time.
///
/// Copies also merge when their spectral peaks are one ([`unresolved`]), however far apart in
/// per cent: such a pair dies before it completes one beat, so it sounds as one partial with
/// the envelope of its sum, which may be far weaker than either copy.
pub fn consolidate_attack_free(modes: &[Mode], rel_sep: f64) -> Vec<Mode> {
    merge_groups(modes, rel_sep, true)
}

/// Whether neighbouring modes `a` and `b` are one peak in spectrum: closer than the sum of
/// their half-power half-bandwidths `σ/2π` (σ the amplitude decay rate, 1/s). Why it matters:
/// the joint fit explains a knock's non-exponential envelope by such pairs at large, nearly
/// opposite amplitudes (an agogo bell's 268 and 274 Hz components, 162° apart, decaying at
/// 1300–1400 dB/s), whose sum is a weak swell; the engine starts every drawn mode with one
/// polarity, so drawn apart the pair plays at the copies' full levels, a thump the recording
/// does not have. A pair that beats (peaks apart by more than their widths) is two partials
/// and stays two. A slow partial within a fast knock's width merges with it; where the partial
/// is isolated, its own track then sets the merged mode's decay and energy
/// ([`super::ringing_modes`]), and the knock's energy is left to the strike noise fitted to
/// what the modes leave. Measured effect, and the narrower rule that measured worse:
/// docs/model.md "Copies whose peaks overlap", docs/fit-alternatives.md.
pub fn unresolved(a: &Mode, b: &Mode) -> bool {
    let half_width_hz = |m: &Mode| m.decay_db_per_s.max(0.0) / DB_PER_NEPER / std::f64::consts::TAU;
    (a.freq_hz - b.freq_hz).abs() < half_width_hz(a) + half_width_hz(b)
}

/// Longest build-up time the merge fits, s ([`fit_build_up`]): four times the extractor's
/// longest ([`crate::fit::recording::extract::ATTACK_GRID_S`]), as the copies of a group can swell more
/// slowly together than any one of them.
pub const MAX_FIT_RISE_S: f64 = 0.256;

/// Points of the sampled envelope in [`fit_build_up`].
const ENVELOPE_POINTS: usize = 2000;

/// `∫₀^∞ e^{−2σt}·(1 − e^{−t/τ})² dt` (σ in 1/s, τ in s; τ = 0: no build-up): the energy of
/// the build-up mode's squared envelope per unit `A²`.
pub fn build_up_energy_integral(sigma: f64, tau_s: f64) -> f64 {
    let s2 = 2.0 * sigma.max(1e-9);
    if tau_s > 0.0 {
        let r = 1.0 / tau_s;
        1.0 / s2 - 2.0 / (s2 + r) + 1.0 / (s2 + 2.0 * r)
    } else {
        1.0 / s2
    }
}

/// Least-squares fit of `A·e^{−σt}·(1 − e^{−t/τ})` to the amplitude envelope
/// `|Σ c_k e^{(−α_k + iΔω_k)t}|` of the complex exponentials `terms` (`(c, b dB/s, f Hz)`, as
/// [`exponentials`]; Δω relative to their mean frequency) over the time the envelope takes to
/// fall 60 dB below its peak: returns (σ in dB/s, τ in s). Linear amplitude, not dB: the fit
/// follows the part of the envelope that carries the sound (its rise and main decay) rather
/// than a weak slow tail. τ from 0 and a third-octave grid up to [`MAX_FIT_RISE_S`], σ by
/// golden-section search for each τ (A is linear: the cost is `Σe² − (Σeφ)²/Σφ²`).
pub fn fit_build_up(terms: &[(realfft::num_complex::Complex<f64>, f64, f64)]) -> Option<(f64, f64)> {
    use realfft::num_complex::Complex;
    if terms.is_empty() {
        return None;
    }
    let alphas: Vec<f64> = terms.iter().map(|t| t.1.max(1e-3) / DB_PER_NEPER).collect();
    let a_min = alphas.iter().cloned().fold(f64::INFINITY, f64::min);
    let a_max = alphas.iter().cloned().fold(0.0, f64::max);
    let f_mean = terms.iter().map(|t| t.2).sum::<f64>() / terms.len() as f64;
    let envelope = |span: f64, out: &mut Vec<f64>| {
        out.clear();
        let dt = span / ENVELOPE_POINTS as f64;
        for i in 0..ENVELOPE_POINTS {
            let t = i as f64 * dt;
            let z: Complex<f64> = terms
                .iter()
                .zip(&alphas)
                .map(|(&(c, _, f), &a)| {
                    c * Complex::from_polar((-a * t).exp(), std::f64::consts::TAU * (f - f_mean) * t)
                })
                .sum();
            out.push(z.norm());
        }
    };
    // Why 7/α_min (≤ 4 s): the slowest term is 60 dB down by then; the span is then cut where
    // the envelope itself stays 60 dB under its peak.
    let mut env = Vec::with_capacity(ENVELOPE_POINTS);
    let span0 = (7.0 / a_min).min(4.0);
    envelope(span0, &mut env);
    let peak = env.iter().cloned().fold(0.0, f64::max);
    if !(peak > 0.0 && peak.is_finite()) {
        return None;
    }
    let last = env.iter().rposition(|&v| v > 1e-3 * peak).unwrap_or(0);
    let span = (span0 * (last + 1) as f64 / ENVELOPE_POINTS as f64).max(0.01_f64.min(span0));
    envelope(span, &mut env);
    let dt = span / ENVELOPE_POINTS as f64;
    let e2: f64 = env.iter().map(|v| v * v).sum();
    // Cost for (ln σ, τ): the residual after the best A.
    let cost = |ln_sigma: f64, tau: f64| -> f64 {
        let q = (-ln_sigma.exp() * dt).exp();
        let qr = if tau > 0.0 { (-dt / tau).exp() } else { 0.0 };
        let (mut g, mut h) = (1.0, 1.0);
        let (mut ep, mut pp) = (0.0, 0.0);
        for &e in &env {
            let phi = g * (1.0 - if tau > 0.0 { h } else { 0.0 });
            ep += e * phi;
            pp += phi * phi;
            g *= q;
            h *= qr;
        }
        if pp > 0.0 {
            e2 - ep * ep / pp
        } else {
            e2
        }
    };
    let golden = |tau: f64| -> (f64, f64) {
        let x = crate::analysis::signal::golden_section_min((0.25 * a_min).ln(), (4.0 * a_max).ln(), |x| {
            cost(x, tau)
        });
        (cost(x, tau), x)
    };
    let mut best = (f64::INFINITY, 0.0, 0.0);
    let mut tau = 0.0;
    while tau <= MAX_FIT_RISE_S {
        let (c, x) = golden(tau);
        if c < best.0 {
            best = (c, x, tau);
        }
        tau = if tau == 0.0 {
            5e-5
        } else {
            tau * 2f64.powf(1.0 / 3.0)
        };
    }
    let (_, ln_sigma, tau) = best;
    Some((DB_PER_NEPER * ln_sigma.exp(), tau)).filter(|v| v.0.is_finite())
}

/// The complex exponentials `(c, b dB/s, f Hz)` whose sum is `m`'s signal: `c·e^{(−α+iω)t}`
/// (`α = b / (20·log10 e)`), and with a build-up τ (when `with_attack`) also
/// `−c·e^{(−α−1/τ+iω)t}`.
fn exponentials(
    m: &Mode,
    with_attack: bool,
) -> impl Iterator<Item = (realfft::num_complex::Complex<f64>, f64, f64)> {
    let c = realfft::num_complex::Complex::from_polar(10f64.powf(m.level_db / 20.0), m.phase);
    let attack = (with_attack && m.attack_s > 0.0)
        .then(|| (-c, m.decay_db_per_s + DB_PER_NEPER / m.attack_s, m.freq_hz));
    std::iter::once((c, m.decay_db_per_s, m.freq_hz)).chain(attack)
}

/// Energy `∫|Σ c_j e^{(−α_j+iω_j)t}|² dt / 2` of the real signal of `g`'s components:
/// `½·Σ_jk Re[c_j c_k* / (α_j + α_k − i(ω_j − ω_k))]` over their [`exponentials`].
fn group_energy(g: &[Mode], with_attack: bool) -> f64 {
    group_energy_moments(g, with_attack).0
}

/// Energy (as [`group_energy`]) and first time moment `∫t·|s|² dt / 2` of `g`'s summed signal:
/// `½·Σ_jk Re[c_j c_k* / (α_j + α_k − i(ω_j − ω_k))²]` (since `∫t·e^{−at} dt = 1/a²`).
fn group_energy_moments(g: &[Mode], with_attack: bool) -> (f64, f64) {
    use realfft::num_complex::Complex;
    let terms: Vec<(Complex<f64>, f64, f64)> = g.iter().flat_map(|x| exponentials(x, with_attack)).collect();
    let (mut e, mut m1) = (0.0, 0.0);
    for &(ca, ba, fa) in &terms {
        for &(cb, bb, fb) in &terms {
            let den = Complex::new(
                (ba + bb).max(1e-3) / DB_PER_NEPER,
                -std::f64::consts::TAU * (fa - fb),
            );
            let q = ca * cb.conj() / den;
            e += 0.5 * q.re;
            m1 += 0.5 * (q / den).re;
        }
    }
    (e, m1)
}

/// Index ranges of the runs of `sorted` (sorted by frequency) whose neighbours lie closer than
/// `rel_sep` × the lower one's frequency, or with `one_peak` also those that are one peak
/// ([`unresolved`]): the groups of near-coincident copies that [`consolidate`] and
/// [`consolidate_attack_free`] merge and [`split_modes`] classifies together.
fn frequency_groups(sorted: &[Mode], rel_sep: f64, one_peak: bool) -> Vec<std::ops::Range<usize>> {
    let mut groups = Vec::new();
    let mut i = 0;
    while i < sorted.len() {
        let mut j = i + 1;
        while j < sorted.len()
            && (sorted[j].freq_hz - sorted[j - 1].freq_hz < rel_sep * sorted[j - 1].freq_hz
                || one_peak && unresolved(&sorted[j - 1], &sorted[j]))
        {
            j += 1;
        }
        groups.push(i..j);
        i = j;
    }
    groups
}

fn merge_groups(modes: &[Mode], rel_sep: f64, with_attack: bool) -> Vec<Mode> {
    use realfft::num_complex::Complex;
    let mut m: Vec<Mode> = modes.to_vec();
    m.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    let mut out = Vec::new();
    for range in frequency_groups(&m, rel_sep, with_attack) {
        let g = &m[range];
        // Weights: onset amplitudes, or with build-ups the amplitude of the attack-free
        // sinusoid of the same energy, so a copy that never swells up does not set the decay.
        let amp = |x: &Mode| {
            if with_attack {
                (4.0 * x.decay_db_per_s.max(1e-3) / DB_PER_NEPER
                    * group_energy(std::slice::from_ref(x), true).max(0.0))
                .sqrt()
            } else {
                10f64.powf(x.level_db / 20.0)
            }
        };
        let w: f64 = g.iter().map(amp).sum::<f64>().max(1e-300);
        let f = g.iter().map(|x| amp(x) * x.freq_hz).sum::<f64>() / w;
        let mean_d = g.iter().map(|x| amp(x) * x.decay_db_per_s).sum::<f64>() / w;
        let (e, m1) = group_energy_moments(g, with_attack);
        // An attack-free mode keeps the group's energy AND its energy's mean time `m1/E`
        // (`1/(2α)` for one damped sinusoid): the copies' amplitude-weighted mean decay is
        // set by a large, fast copy that mostly cancels a slow one at the onset (a build-up
        // the joint fit models as a difference of two sinusoids), and a mode that decays at
        // that rate with the group's energy puts it all in the first milliseconds, a click
        // the recording does not have.
        let builds_up = with_attack && g.iter().any(|x| x.attack_s > 0.0);
        let fitted = if builds_up && e > 0.0 {
            let terms: Vec<_> = g.iter().flat_map(|x| exponentials(x, true)).collect();
            fit_build_up(&terms)
        } else {
            None
        };
        let (d, rise_s) = match fitted {
            Some(v) => v,
            None if with_attack && e > 0.0 && m1 > 0.0 => (DB_PER_NEPER * e / (2.0 * m1), 0.0),
            None => (mean_d, 0.0),
        };
        let alpha = d.max(1e-3) / DB_PER_NEPER;
        // The level that gives the model the group's energy `E = ½·A²·∫(envelope/A)²`.
        let level_db = if rise_s > 0.0 {
            10.0 * (2.0 * e.max(1e-300) / build_up_energy_integral(alpha, rise_s)).log10()
        } else {
            10.0 * (4.0 * alpha * e.max(1e-300)).log10()
        };
        let phase = g
            .iter()
            .map(|x| Complex::from_polar(amp(x), x.phase))
            .sum::<Complex<f64>>()
            .arg();
        out.push(Mode {
            freq_hz: f,
            level_db,
            decay_db_per_s: d,
            phase,
            attack_s: if with_attack {
                rise_s
            } else {
                g.iter().map(|x| amp(x) * x.attack_s).sum::<f64>() / w
            },
            // Rings are fitted to the merged modes (`ring::fit_rings`), never merged.
            ring: None,
        });
    }
    out.sort_by(|a, b| build_up_energy_db(b).total_cmp(&build_up_energy_db(a)));
    out
}

/// A mode's energy in dB (up to the constant of [`energy_db`]) counting its build-up
/// ([`Mode::attack_s`]): equal to [`energy_db`] without one.
pub fn build_up_energy_db(m: &Mode) -> f64 {
    if m.attack_s <= 0.0 {
        return energy_db(m);
    }
    let alpha = m.decay_db_per_s.max(1e-3) / DB_PER_NEPER;
    energy_db(m) + 10.0 * (2.0 * alpha * build_up_energy_integral(alpha, m.attack_s)).log10()
}

/// Relative frequency separation below which [`consolidate`] merges modes (1 %, 17 cents).
pub const CONSOLIDATE_REL: f64 = 0.01;

/// Lowest frequency a mode may have, Hz: the bottom of hearing. Below it a fitted "mode" is
/// the recording's DC drift or handling rumble, and pooled with real lowest modes it widens
/// their distribution by octaves.
pub const MIN_MODE_HZ: f64 = 20.0;

/// Fastest decay, dB/s, a component at `freq_hz` may have and still count as a mode: that of
/// the engine's transient bands, whose one-ERB band-pass rings down at `π·ERB(f)` 1/s
/// (amplitude), `20·log10(e)·π·ERB(f)` dB/s. A component dying faster cannot be told from band
/// noise at that frequency: it is strike noise, and the transient reproduces it.
pub fn max_mode_decay_db_per_s(freq_hz: f64) -> f64 {
    DB_PER_NEPER * std::f64::consts::PI * crate::engine::dsp::scales::erb_bandwidth_hz(freq_hz)
}

/// Splits a recording's extracted components into (modes, strike noise). Modes are finite,
/// at or above [`MIN_MODE_HZ`] and the analysis' frequency resolution `fs / n` (`n` samples
/// analysed; a component slower than one cycle per recording is not a resonance that was
/// observed) and below 0.49·fs; non-finite or sub-audio components are dropped. Strike noise
/// is a group of components within [`CONSOLIDATE_REL`] of each other (the copies
/// [`consolidate`] merges) whose amplitude-weighted decay is faster than
/// [`max_mode_decay_db_per_s`]: it is left to the transient fit (it is not resynthesised as
/// modes, so the transient's band energies take it up). Why by group: the joint fit models a
/// non-exponential envelope with near-coincident copies of large, cancelling amplitudes, one
/// of them often fast; removing that copy alone would leave its partner's excess.
pub fn split_modes(components: &[Mode], fs: f64, n: usize) -> (Vec<Mode>, Vec<Mode>) {
    let low_hz = MIN_MODE_HZ.max(fs / n.max(1) as f64);
    let mut m: Vec<Mode> = components
        .iter()
        .filter(|m| {
            m.freq_hz.is_finite()
                && m.level_db.is_finite()
                && m.decay_db_per_s.is_finite()
                && m.phase.is_finite()
                && m.attack_s.is_finite()
                && m.freq_hz >= low_hz
                && m.freq_hz < 0.49 * fs
        })
        .copied()
        .collect();
    m.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    let (mut modes, mut noise) = (Vec::new(), Vec::new());
    for range in frequency_groups(&m, CONSOLIDATE_REL, false) {
        let g = &m[range];
        let amp = |x: &Mode| 10f64.powf(x.level_db / 20.0);
        let w: f64 = g.iter().map(amp).sum();
        let f = g.iter().map(|x| amp(x) * x.freq_hz).sum::<f64>() / w;
        let d = g.iter().map(|x| amp(x) * x.decay_db_per_s).sum::<f64>() / w;
        if d > max_mode_decay_db_per_s(f) {
            noise.extend_from_slice(g);
        } else {
            modes.extend_from_slice(g);
        }
    }
    // Strongest first, as extracted.
    let order = |v: &mut Vec<Mode>| v.sort_by(|a, b| b.level_db.total_cmp(&a.level_db));
    order(&mut modes);
    order(&mut noise);
    (modes, noise)
}
