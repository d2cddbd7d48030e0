//! The noise-band transient of a preset (docs/model.md §3, Traer et al. 2019 eq. 3): per ERB
//! band, the energy a recording's modes leave unexplained, fitted as band noise with a level and
//! a decay, refit for the leakage of the engine's draws, and pooled over recordings into a
//! Gaussian beside the mode distribution ([`crate::fit::pool::distribution`]).

use crate::analysis::features::ATTACK_WINDOW_S;
use crate::analysis::partials;
use crate::analysis::signal::decay_from_track;
use crate::engine::dsp::scales::{erb_bandwidth_hz, erb_centres};
use crate::engine::dsp::DB_PER_NEPER;
use crate::fit::recording::bands::{
    analysis_high_hz, band_bins, band_energies, band_energies_up_to, band_envelope, padded_spectrum,
    transient_band_signals, transient_leakage, BANDS, BAND_HIGH_HZ, BAND_LOW_HZ,
};
use realfft::RealFftPlanner;

/// Per-band short-time power tracks (mean power of the band signal per frame, Parseval on a
/// ×4 zero-padded Hann frame of ~6 ms, 1/4 hop) of each signal in `xs`, on the same frames.
/// Returns (frame centre times s, per signal per band the power track);
/// a band is `None` above 0.49·fs.
fn band_power_tracks(xs: &[&[f64]], fs: f64) -> (Vec<f64>, Vec<Vec<Option<Vec<f64>>>>) {
    let nw = ((0.006 * fs) as usize).next_power_of_two().max(64);
    let hop = nw / 4;
    let nfft = nw * 4;
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let w = crate::analysis::signal::hann(nw);
    let w2: f64 = w.iter().map(|v| v * v).sum();
    let n = xs.iter().map(|x| x.len()).min().unwrap_or(0);
    let mut times = Vec::new();
    let mut start = 0;
    while start + nw <= n {
        times.push((start as f64 + 0.5 * nw as f64) / fs);
        start += hop;
    }
    let mut buf = vec![0.0; nfft];
    let mut spec = fft.make_output_vec();
    let edges = band_bins(fs, nfft, BAND_HIGH_HZ);
    let out = xs
        .iter()
        .map(|x| {
            let mut tracks: Vec<Vec<f64>> = (0..BANDS).map(|_| Vec::with_capacity(times.len())).collect();
            for k in 0..times.len() {
                let s0 = k * hop;
                buf.iter_mut().for_each(|v| *v = 0.0);
                for i in 0..nw {
                    buf[i] = x[s0 + i] * w[i];
                }
                fft.process(&mut buf, &mut spec).expect("fft sizes");
                for (j, e) in edges.iter().enumerate() {
                    if let Some((a, b)) = e {
                        let p: f64 = spec[*a..=*b].iter().map(|c| c.norm_sqr()).sum();
                        tracks[j].push((2.0 / (nfft as f64 * w2)) * p);
                    }
                }
            }
            edges.iter().zip(tracks).map(|(e, t)| e.map(|_| t)).collect()
        })
        .collect();
    (times, out)
}

/// Transient per band (onset level dB re full scale RMS of the band noise, decay dB/s) fitted to
/// the energy the modes do *not* explain: per ERB band and short-time frame, the recording's
/// power minus the modal resynthesis's power, clipped at zero (the noise adds power, it cannot
/// remove any). The decay is the line fit of that gap's dB track ([`GapDecay::Line`]); the level
/// makes the band noise's total energy (whole signal, [`band_energies`]) equal to the gap's. Why
/// not band levels of the residual `y − modal`: the residual also holds the modes' misfit, which
/// is as often excess as missing energy, and band noise fitted to it adds that misfit a second
/// time. `None` for
/// bands above 0.49·fs.
pub fn fit_transient_gap(y: &[f64], modal: &[f64], fs: f64) -> Vec<Option<(f64, f64)>> {
    fit_transient_gap_decaying(y, modal, fs, 0.0, GapDecay::Line)
}

/// How [`fit_transient_gap_decaying`] reads a band's decay off the gap.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GapDecay {
    /// The line fit of the gap's dB track from its maximum ([`decay_from_track`]): the
    /// strike's own fall, where the gap is the strike (a sparse object's modes explain the
    /// rest).
    Line,
    /// The decay that gives the band noise the share of the gap's energy that falls in its
    /// first [`ATTACK_WINDOW_S`], the window of the attack share the ear and `tactus eval`
    /// judge: `−10·log10(1 − share)/window` dB/s. For a gap that is strike and wash at once
    /// (what a dense object's counted partials leave): one exponential per band cannot follow
    /// both, and this one puts the energy where the recording has it. Why not the line there:
    /// the modes explain a frame's power as often as not, the gap is zero in those frames, and
    /// a line from the maximum stops at the first such dip and reads the strike's fast fall; the
    /// level then put the whole gap's energy, mostly wash, into the first milliseconds
    /// (docs/model.md, "What a preset pools"). Why not the backward integral's first 10 or 30 dB
    /// (as `tactus eval` reads a partial's decay): they follow the wash and leave too little of
    /// the strike (docs/fit-alternatives.md).
    /// Why not for every object: a sparse object's gap also holds its room and the tails of
    /// partials too weak to count, and noise that rings at their rate counts as spectral peaks
    /// (docs/fit-alternatives.md).
    EarlyShare,
}

/// [`fit_transient_gap`] without the bands whose gap decays slower than `slowest_db_per_s`
/// (`None`). Why: the band noise stands for the strike and the object's unresolved response,
/// which decays at its modes' rates, so a band that rings on long after the object's slowest
/// mode is the recording's, its noise floor or room. The pipeline passes half the slowest pooled
/// mode's decay (twice its T60), a bound between the two groups measured on the 26 recordings:
/// ten gap bands at 1–8 dB/s in nine files whose slowest mode decays at 9–53 dB/s (by the fitted
/// means, three of them alone held 16–27 dB under their object's total energy in 0.5–1.5 s, a
/// hiss over the whole sound; docs/presets.md), and bands at 41–49 dB/s, the rate of the modes,
/// in a marimba whose slowest mode decays at 50 dB/s.
pub fn fit_transient_gap_decaying(
    y: &[f64],
    modal: &[f64],
    fs: f64,
    slowest_db_per_s: f64,
    read: GapDecay,
) -> Vec<Option<(f64, f64)>> {
    let n = y.len().min(modal.len());
    let (times, tr) = band_power_tracks(&[&y[..n], &modal[..n]], fs);
    if times.len() < 3 {
        return vec![None; BANDS];
    }
    let top = tr[0]
        .iter()
        .flatten()
        .flat_map(|t| t.iter().cloned())
        .fold(1e-300, f64::max);
    // Why −90 dB re the strongest band frame: below a 16-bit recording's floor; keeps the dB
    // track finite where the modes explain everything.
    let eps = top * 1e-9;
    // Band energies of the whole signals in the transient's own bands: the 6 ms frames resolve
    // the decay but not the narrow low bands (a 50 Hz band's frame power is mostly leakage from
    // modes a few hundred Hz up), so the level comes from here.
    let (ey, em) = (band_energies(&y[..n], fs), band_energies(&modal[..n], fs));
    let mut centres = Vec::new();
    erb_centres(BANDS, BAND_LOW_HZ, BAND_HIGH_HZ, &mut centres);
    let gap_energy: Vec<f64> = ey.iter().zip(&em).map(|(a, b)| (a - b).max(0.0)).collect();
    // The gap's share in the attack window, by the same band energies as the level.
    let early_share: Vec<Option<f64>> = if read == GapDecay::EarlyShare {
        let k = ((ATTACK_WINDOW_S * fs).round() as usize).min(n);
        let (ey, em) = (band_energies(&y[..k], fs), band_energies(&modal[..k], fs));
        ey.iter()
            .zip(&em)
            .zip(&gap_energy)
            .map(|((a, b), &g)| (g > 0.0).then(|| ((a - b).max(0.0) / g).min(1.0)))
            .collect()
    } else {
        vec![None; gap_energy.len()]
    };
    let first: Vec<Option<(f64, f64)>> = tr[0]
        .iter()
        .zip(&tr[1])
        .enumerate()
        .map(|(band, (py, pm))| {
            let (py, pm) = (py.as_ref()?, pm.as_ref()?);
            let gap: Vec<f64> = py.iter().zip(pm).map(|(a, b)| (a - b).max(0.0)).collect();
            let l: Vec<f64> = gap.iter().map(|g| 10.0 * (g + eps).log10()).collect();
            // Why at most π·ERB (in 1/s, ×8.69 for dB/s): a band-limited noise cannot die
            // faster than its bandwidth allows; a faster envelope smears the band's energy over
            // its neighbours (a 50 Hz band at 5·10⁴ dB/s is ~900 Hz wide).
            let max_decay = DB_PER_NEPER * std::f64::consts::PI * erb_bandwidth_hz(centres[band]);
            let decay = match read {
                GapDecay::Line => decay_from_track(&times, &l).unwrap_or(1000.0),
                // A band the modes leave nothing in has nothing to play: a fast band there
                // would only take its neighbours' energy in the level refit below.
                GapDecay::EarlyShare => {
                    let share = -10.0 * (1.0 - early_share[band]?).max(1e-12).log10() / ATTACK_WINDOW_S;
                    share.max(beside_decay(&times, pm, ey[band], em[band]).unwrap_or(0.0))
                }
            }
            .clamp(1.0, max_decay);
            if decay < slowest_db_per_s {
                return None;
            }
            let energy = gap_energy[band];
            // The energy of a unit-level band over the n samples.
            let unit: f64 = band_envelope(decay, erb_bandwidth_hz(centres[band]), fs, n)
                .iter()
                .map(|v| v * v)
                .sum();
            Some((10.0 * (energy / unit).max(eps).log10(), decay))
        })
        .collect();
    let high = analysis_high_hz(fs);
    let (ay, am) = (
        band_energies_up_to(&y[..n], fs, high),
        band_energies_up_to(&modal[..n], fs, high),
    );
    let expected = refit_transient_levels(&first, &ay, &am, fs, n);
    let u = refit_for_draws(&first, expected, &ay, &modal[..n], fs);
    first
        .iter()
        .zip(&u)
        .map(|(b, &ui)| {
            let (lvl, d) = (*b)?;
            let refit = 10.0 * ui / std::f64::consts::LN_10;
            Some((if refit.is_finite() { refit } else { lvl }, d))
        })
        .collect()
}

/// Share of a band's energy the modes beside its noise must hold for [`beside_decay`] to bound
/// the noise's decay by theirs (−20 dB): below it the band's modal power is other bands'
/// leakage.
const BESIDE_MIN_SHARE: f64 = 0.01;

/// The decay (dB/s) of the energy of the modes that play beside a dense object's band noise,
/// read off their band's power track `pm` (frames at `times`) as `tactus eval` reads a band's
/// ring ([`partials::energy_decay_from_track`]); `None` where they hold less than
/// [`BESIDE_MIN_SHARE`] of the band's energy (`modal` of `total`). Why [`GapDecay::EarlyShare`]
/// decays no slower: the noise stands for the strike and the wash of partials too close to
/// count, which rings as the partials do. Where the wash swells after the strike, the first
/// 10 ms hold a small share of the gap's energy, and that share alone read decays of 1–4 dB/s
/// at 4–16 kHz in a crash cymbal whose partials there decay at 17–29 dB/s: a hiss that outlasts
/// the cymbal and, drawn, rang its bands longer than its recording's.
fn beside_decay(times: &[f64], pm: &[f64], total: f64, modal: f64) -> Option<f64> {
    if !(modal >= BESIDE_MIN_SHARE * total && modal > 0.0) {
        return None;
    }
    let top = pm.iter().cloned().fold(0.0, f64::max);
    let l: Vec<f64> = pm.iter().map(|p| 10.0 * (p + top * 1e-12).log10()).collect();
    partials::energy_decay_from_track(times, &l)
}

/// Levenberg–Marquardt iterations of [`refit_transient_levels`] and [`refit_for_draws`].
const LEAKAGE_ITERATIONS: usize = 30;

/// Refits the transient bands' levels (decays kept) so that the modes' band energies `em` plus
/// the bands' *expected leaked* energies ([`transient_leakage`]) match the recording's `ey` in the
/// least-squares sense on the dB scale, over the bands within 60 dB of the recording's strongest.
/// `ey` and `em` are in the bands the recording is judged in (centres up to
/// [`analysis_high_hz`], those of [`erb_log_spectral_distance`]), not the transient's own: below
/// 35.6 kHz the two grids differ, and levels fitted in the transient's grid miss the bands the
/// distance judges. Why a refit: the first fit
/// gives each band the energy missing in that band alone, but a fast-decaying band spreads into
/// its neighbours and overfilled the weak ones. No band's total energy is set below 60 dB under
/// the strongest band (where the distance stops looking), so a band the modes overfill does not
/// sink towards −∞ dB and skew the preset's transient distribution. Returns the levels as energy
/// factors `u = ln 10^(lvl/10)` (−∞ for a band without a fit) and the 60 dB floor of each band.
fn refit_transient_levels(
    bands: &[Option<(f64, f64)>],
    ey: &[f64],
    em: &[f64],
    fs: f64,
    n: usize,
) -> (Vec<f64>, Vec<f64>) {
    let decays: Vec<Option<f64>> = bands.iter().map(|b| b.map(|(_, d)| d)).collect();
    let t = transient_leakage(&decays, fs, n, analysis_high_hz(fs));
    let top = ey.iter().cloned().fold(0.0, f64::max);
    let fl = top * 1e-6;
    let used: Vec<usize> = (0..ey.len()).filter(|&j| ey[j] > 0.0).collect();
    let free: Vec<usize> = (0..bands.len())
        .filter(|&i| bands[i].is_some() && t[i].iter().sum::<f64>() > 0.0)
        .collect();
    let floor: Vec<f64> = (0..bands.len())
        .map(|i| (fl / t[i].iter().sum::<f64>()).ln())
        .collect();
    let mut u: Vec<f64> = bands
        .iter()
        .enumerate()
        .map(|(i, b)| {
            b.map_or(f64::NEG_INFINITY, |(lvl, _)| {
                (lvl / 10.0 * std::f64::consts::LN_10).max(floor[i])
            })
        })
        .collect();
    let target: Vec<f64> = used.iter().map(|&j| ey[j]).collect();
    // E_j = em_j + Σ_i e^{u_i}·T_ij; ∂E_j/∂u_i = e^{u_i}·T_ij.
    fit_log_levels(&mut u, &free, &floor, &target, fl, |u, jac| {
        let e = used
            .iter()
            .map(|&j| em[j] + free.iter().map(|&i| u[i].exp() * t[i][j]).sum::<f64>() + 1e-300)
            .collect();
        let d = if jac {
            used.iter()
                .map(|&j| free.iter().map(|&i| u[i].exp() * t[i][j]).collect())
                .collect()
        } else {
            Vec::new()
        };
        (e, d)
    });
    (u, floor)
}

/// Noise draws [`refit_for_draws`] averages over, and the first of their seeds. Why seeds from
/// 1000: the resynthesis distance is reported with seeds 1…8, which the levels must not be fitted
/// to.
const FIT_DRAWS: u64 = 8;
const FIT_SEED: u64 = 1_000;
/// Longest transform [`refit_for_draws`] works with: it holds one spectrum per transient band
/// (30 × 2¹⁸ complex values, 126 MB at this size, i.e. recordings up to 2¹⁹ samples, 11.9 s at
/// 44.1 kHz). Longer recordings keep the expected-energy levels of [`refit_transient_levels`].
const MAX_DRAW_FFT: usize = 1 << 19;

/// Refines the levels of [`refit_transient_levels`] (energy factors `u`, floors `floor`) for the
/// *mean over noise draws* of the squared dB error, instead of the error of the expected band
/// energies. Why: the band energy of one resynthesis is `|M + Σ_i g_i·S_i|²` summed over the
/// band's bins (`M` the modes' spectrum, `S_i` transient band `i`'s unit draw, `g_i² = e^{u_i}`),
/// and its cross term `2·Re(M·S_i*)` has zero mean but a spread of several dB where a band's
/// noise meets a mode of similar energy (a single mode is one complex degree of freedom). Levels
/// fitted to the expected energy fill such bands and leave each draw several dB off; the mean
/// over draws weighs that spread against the gap the noise fills. Sample-average
/// approximation over [`FIT_DRAWS`] draws of [`transient_band_signals`] (seeds from
/// [`FIT_SEED`]); each draw's band energy is exact in the gains: `E = em + 2·Σ g_i·C_i +
/// Σ g_i·g_k·D_ik` with `C_i = ⟨M, S_i⟩_band`, `D_ik = ⟨S_i, S_k⟩_band`.
fn refit_for_draws(
    bands: &[Option<(f64, f64)>],
    (u, floor): (Vec<f64>, Vec<f64>),
    ey: &[f64],
    modal: &[f64],
    fs: f64,
) -> Vec<f64> {
    if modal.len().next_power_of_two() > MAX_DRAW_FFT {
        return u;
    }
    let top = ey.iter().cloned().fold(0.0, f64::max);
    let fl = top * 1e-6;
    let used: Vec<usize> = (0..ey.len()).filter(|&j| ey[j] > 0.0).collect();
    let decays: Vec<Option<f64>> = bands.iter().map(|b| b.map(|(_, d)| d)).collect();
    let free: Vec<usize> = (0..bands.len()).filter(|&i| u[i].is_finite()).collect();
    let obs = draw_observations(&decays, &free, &used, modal, fs, FIT_SEED..FIT_SEED + FIT_DRAWS);
    let target: Vec<f64> = obs.iter().map(|o| ey[o.band]).collect();
    let mut u = u;
    fit_log_levels(&mut u, &free, &floor, &target, fl, |u, jac| {
        let g: Vec<f64> = free.iter().map(|&i| (0.5 * u[i]).exp()).collect();
        let mut e = Vec::with_capacity(obs.len());
        let mut rows = Vec::new();
        for o in &obs {
            let (v, h) = o.energy(&g);
            e.push(v + 1e-300);
            if jac {
                let mut row = vec![0.0; free.len()];
                for (p, &a) in o.active.iter().enumerate() {
                    row[a] = g[a] * h[p];
                }
                rows.push(row);
            }
        }
        (e, rows)
    });
    u
}

/// One judged band of one noise draw, as a function of the transient gains `g` (over the fitted
/// bands `free`): `E = em + 2·Σ_p g_p·C_p + Σ_pq g_p·g_q·D_pq` over the `active` bands, those
/// whose draw holds ≥ 10⁻⁹ of its energy here.
struct DrawBand {
    band: usize,
    em: f64,
    active: Vec<usize>,
    c: Vec<f64>,
    d: Vec<f64>,
}

impl DrawBand {
    /// The band energy at gains `g`, and `h_p = C_p + Σ_q g_q·D_pq` (so `∂E/∂u_p = g_p·h_p` for
    /// `g_p = e^{u_p/2}`).
    fn energy(&self, g: &[f64]) -> (f64, Vec<f64>) {
        let k = self.active.len();
        let h: Vec<f64> = (0..k)
            .map(|p| self.c[p] + (0..k).map(|q| g[self.active[q]] * self.d[p * k + q]).sum::<f64>())
            .collect();
        let v: f64 = (0..k).map(|p| g[self.active[p]] * (self.c[p] + h[p])).sum();
        ((self.em + v).max(0.0), h)
    }
}

/// The [`DrawBand`]s of the judged bands `used` ([`band_energies_up_to`] up to
/// [`analysis_high_hz`]) for each seed of `seeds`: spectra of the modes `modal` and of each band
/// of `free` drawn by [`transient_band_signals`].
fn draw_observations(
    decays: &[Option<f64>],
    free: &[usize],
    used: &[usize],
    modal: &[f64],
    fs: f64,
    seeds: std::ops::Range<u64>,
) -> Vec<DrawBand> {
    use realfft::num_complex::Complex;
    let n = modal.len();
    let nfft = n.next_power_of_two().max(2);
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(nfft);
    let spectrum = |x: &[f64]| padded_spectrum(&*fwd, x);
    let bins = band_bins(fs, nfft, analysis_high_hz(fs));
    let m = spectrum(modal);
    let scale = 2.0 / nfft as f64;
    let dot = |a: &[Complex<f64>], b: &[Complex<f64>], (lo, hi): (usize, usize)| -> f64 {
        scale * (lo..=hi).map(|k| (a[k] * b[k].conj()).re).sum::<f64>()
    };
    let mut obs = Vec::new();
    for seed in seeds {
        let sig = transient_band_signals(decays, fs, n, seed);
        let spec: Vec<Option<Vec<Complex<f64>>>> = free
            .iter()
            .map(|&i| sig[i].as_ref().map(|x| spectrum(x)))
            .collect();
        let own: Vec<f64> = spec
            .iter()
            .map(|s| {
                s.as_ref()
                    .map_or(0.0, |s| scale * s.iter().map(|c| c.norm_sqr()).sum::<f64>())
            })
            .collect();
        for &j in used {
            let Some(b) = bins[j] else { continue };
            let active: Vec<usize> = (0..free.len())
                .filter(|&a| spec[a].as_ref().is_some_and(|s| dot(s, s, b) > 1e-9 * own[a]))
                .collect();
            let at = |a: usize| spec[a].as_ref().expect("active bands have a draw");
            let c = active.iter().map(|&a| dot(&m, at(a), b)).collect();
            let k = active.len();
            let mut d = vec![0.0; k * k];
            for p in 0..k {
                for q in 0..=p {
                    let v = dot(at(active[p]), at(active[q]), b);
                    d[p * k + q] = v;
                    d[q * k + p] = v;
                }
            }
            obs.push(DrawBand {
                band: j,
                em: dot(&m, &m, b),
                active,
                c,
                d,
            });
        }
    }
    obs
}

/// Levenberg–Marquardt on the energy factors `u[i]` (i in `free`, each kept ≥ `floor[i]`) of a
/// model that returns, per observation, a band energy `E_o` and (when asked) `∂E_o/∂u` over
/// `free`. Residual: `ln(E_o/target_o)` where the target is over the 60 dB floor `fl`; under it,
/// only the excess `ln(max(E_o, fl)/fl)`. Why the excess term: such bands are free to fill their
/// neighbours by leakage, and without it they did so at any level of their own; a 24 kHz steel
/// drum got bands 5–11 kHz 40 dB over the recording.
fn fit_log_levels(
    u: &mut Vec<f64>,
    free: &[usize],
    floor: &[f64],
    target: &[f64],
    fl: f64,
    model: impl Fn(&[f64], bool) -> (Vec<f64>, Vec<Vec<f64>>),
) {
    let resid = |o: usize, e: f64| -> f64 {
        if target[o] > fl {
            (e / target[o]).ln()
        } else {
            (e.max(fl) / fl).ln()
        }
    };
    let cost = |e: &[f64]| -> f64 { e.iter().enumerate().map(|(o, &v)| resid(o, v).powi(2)).sum() };
    let mut c = cost(&model(u, false).0);
    let mut lambda = 1e-2;
    let k = free.len();
    for _ in 0..LEAKAGE_ITERATIONS {
        let (e, de) = model(u, true);
        let mut jtj = vec![vec![0.0; k]; k];
        let mut jtr = vec![0.0; k];
        for (o, (&eo, row)) in e.iter().zip(&de).enumerate() {
            let r = resid(o, eo);
            if r == 0.0 && target[o] <= fl {
                continue;
            }
            let row: Vec<f64> = row.iter().map(|v| v / eo).collect();
            for a in 0..k {
                jtr[a] += row[a] * r;
                for b in 0..=a {
                    jtj[a][b] += row[a] * row[b];
                }
            }
        }
        let mut accepted = false;
        for _ in 0..8 {
            let mut g = jtj.clone();
            for a in 0..k {
                for b in 0..a {
                    g[b][a] = g[a][b];
                }
                g[a][a] += lambda * g[a][a] + 1e-12;
            }
            let Some(l) = crate::engine::dsp::linalg::cholesky(&g) else {
                lambda *= 10.0;
                continue;
            };
            let step = crate::engine::dsp::linalg::cholesky_solve(&l, &jtr);
            let mut trial = u.clone();
            for (a, &i) in free.iter().enumerate() {
                trial[i] = (u[i] - step[a]).max(floor[i]);
            }
            let tc = cost(&model(&trial, false).0);
            if tc.is_finite() && tc < c {
                (*u, c) = (trial, tc);
                lambda = (lambda / 3.0).max(1e-9);
                accepted = true;
                break;
            }
            lambda *= 10.0;
        }
        if !accepted {
            break;
        }
    }
}

#[cfg(test)]
#[path = "transient_tests.rs"]
mod tests;
