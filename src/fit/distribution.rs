//! Pooling fitted recordings of one material into a preset (docs/model.md §3, Traer et al. 2019
//! §2.1 eq. 4): a multivariate Gaussian over `[levels dB, ln decay dB/s, log2 Hz]` of each
//! recording's strongest modes ordered by frequency rank, with Schäfer–Strimmer/Ledoit–Wolf
//! shrinkage of the correlations toward zero (target "diagonal, unequal variances") because there
//! are fewer recordings than parameters; and the noise-band transient (Traer eq. 3) fitted per
//! ERB band to the energy the modes leave unexplained.

use crate::engine::object::{build_up_peak_factor, erb_bandwidth_hz, erb_centres, spacing_octaves};
pub use crate::fit::bands::{
    analysis_high_hz, band_energies, band_energies_up_to, erb_log_spectral_distance, synthesize_transient,
    transient_band_signals, transient_leakage, BANDS, BAND_HIGH_HZ, BAND_LOW_HZ,
};
use crate::fit::bands::{band_bins, band_envelope, padded_spectrum};
use crate::fit::extract::{decay_from_track, energy_db, Mode};
use crate::preset::{DampingModel, DecayCoordinates, Gaussian, ModeDistribution, TransientDistribution};
use realfft::RealFftPlanner;

/// Level of the strongest mean mode after normalisation, dB (the engine's gain staging assumes
/// per-mode onset levels of about −6…−40 dB re 1 per N·s).
pub const TOP_LEVEL_DB: f64 = -6.0;

/// Largest boost, dB, that [`ContactCompensation`] gives a mode or band. Why a cap: the
/// default contact's spectrum falls as `f⁻²` above `1/(2τ)`; un-capped, a wood preset's modes
/// at 8 kHz would be raised 36 dB, and a heavier or softer strike than the default, which cuts
/// them again, would leave the fitted level's noise amplified. 24 dB restores the recordings'
/// balance up to about 4 kHz for wood and 12 kHz for metal at the default strike.
pub const MAX_CONTACT_BOOST_DB: f64 = 24.0;

/// The contact the engine's default strike applies to a preset (docs/model.md, "Fitted levels
/// and the default strike"). The recordings already carry their mallet's spectrum; the engine
/// filters every mode by its own contact spectrum `|F(f)|/J` again, and every transient band
/// by that spectrum's smooth envelope `1/√(1 + (2fτ)⁴)`. Fitted levels are raised by the
/// inverse of that envelope at the default strike, so the default hit reproduces the
/// recordings' spectral balance, and mass and hardness act relative to it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactCompensation {
    /// Duration τ of the default contact, s.
    pub duration_s: f64,
}

impl ContactCompensation {
    /// The engine's default strike (default settings' mass, hardness and contact model, 1 m/s)
    /// on a preset of contact stiffness `stiffness_n_per_m`.
    pub fn default_strike(stiffness_n_per_m: f64) -> Self {
        use crate::engine::force::{ImpactForce, ImpactParams};
        let s = crate::engine::Settings::default().impact;
        let mut force = ImpactForce::default();
        force.start(
            &ImpactParams::new(s.mass_kg, 1.0, stiffness_n_per_m * s.hardness, s.contact_model),
            192_000.0,
        );
        Self {
            duration_s: force.duration_s(),
        }
    }

    /// Boost in dB at `freq_hz`: `10·log10(1 + (2fτ)⁴)`, at most [`MAX_CONTACT_BOOST_DB`].
    pub fn boost_db(&self, freq_hz: f64) -> f64 {
        let x = 2.0 * freq_hz * self.duration_s;
        let b = 10.0 * (1.0 + x.powi(4)).log10();
        if b.is_finite() {
            b.clamp(0.0, MAX_CONTACT_BOOST_DB)
        } else {
            0.0
        }
    }
}

/// Variance floors per block (level dB², ln-decay², log2-Hz²). Why: a parameter that never varied
/// in a handful of recordings still varies between objects; these are ~1 dB, ~3 %, ~1 cent.
const VAR_FLOOR: [f64; 3] = [1.0, 1e-3, 1e-4];
/// Variance floors for a family fitted from fewer than 3 recordings: ~3 dB, ~20 %, ~0.05
/// octave (a few percent of size between objects of one kind).
const FEW_VAR_FLOOR: [f64; 3] = [9.0, 0.04, 0.0025];

/// Sample covariance with Schäfer–Strimmer shrinkage of the correlations; `rows` are samples.
/// Returns (mean, covariance, λ).
pub fn shrunk_covariance(rows: &[Vec<f64>]) -> (Vec<f64>, Vec<Vec<f64>>, f64) {
    let n = rows.len();
    let p = rows[0].len();
    let nf = n as f64;
    let mean: Vec<f64> = (0..p)
        .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / nf)
        .collect();
    let sd: Vec<f64> = (0..p)
        .map(|j| (rows.iter().map(|r| (r[j] - mean[j]).powi(2)).sum::<f64>() / (nf - 1.0).max(1.0)).sqrt())
        .collect();
    let z: Vec<Vec<f64>> = rows
        .iter()
        .map(|r| {
            (0..p)
                .map(|j| {
                    if sd[j] > 0.0 {
                        (r[j] - mean[j]) / sd[j]
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let mut corr = vec![vec![0.0; p]; p];
    let (mut num, mut den) = (0.0, 0.0);
    for i in 0..p {
        for j in 0..p {
            if i == j {
                continue;
            }
            let w: Vec<f64> = z.iter().map(|r| r[i] * r[j]).collect();
            let wm = w.iter().sum::<f64>() / nf;
            let rij = nf / (nf - 1.0).max(1.0) * wm;
            corr[i][j] = rij;
            num += nf / (nf - 1.0).max(1.0).powi(3) * w.iter().map(|v| (v - wm).powi(2)).sum::<f64>();
            den += rij * rij;
        }
    }
    let lambda = if den > 0.0 {
        (num / den).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let mut cov = vec![vec![0.0; p]; p];
    for i in 0..p {
        for j in 0..p {
            cov[i][j] = if i == j {
                sd[i] * sd[i]
            } else {
                (1.0 - lambda) * corr[i][j] * sd[i] * sd[j]
            };
        }
    }
    (mean, cov, lambda)
}

fn make_pd(cov: &mut [Vec<f64>], floors: &[f64]) {
    let p = cov.len();
    for i in 0..p {
        cov[i][i] = cov[i][i].max(floors[i]);
    }
    // Shrink the off-diagonal further until Cholesky succeeds (always does at 0).
    let mut k = 0;
    while crate::preset::cholesky(cov).is_none() && k < 60 {
        for i in 0..p {
            for j in 0..p {
                if i != j {
                    cov[i][j] *= 0.8;
                }
            }
        }
        k += 1;
    }
    if crate::preset::cholesky(cov).is_none() {
        for i in 0..p {
            for j in 0..p {
                if i != j {
                    cov[i][j] = 0.0;
                }
            }
        }
    }
}

/// Fits the mode distribution from per-recording modes. `count` modes per object (each
/// recording's `count` strongest by energy, sorted by frequency; pass modes through
/// [`crate::fit::extract::consolidate`] first). Levels are normalised per recording to
/// its strongest mode (recording gains are arbitrary), then shifted so the strongest mean level
/// is [`TOP_LEVEL_DB`]. With a damping `law`, the decay block holds each mode's deviation from
/// the law at its frequency ([`DecayCoordinates::DampingResidual`]), so draws keep the
/// recordings' growth of decay with frequency. Errors if there is no recording, one has fewer
/// than `count` modes, or a value is not finite.
pub fn fit_modes(
    files: &[Vec<Mode>],
    count: usize,
    law: Option<&DampingModel>,
) -> anyhow::Result<ModeDistribution> {
    if files.is_empty() {
        anyhow::bail!("need at least 1 recording to fit a distribution");
    }
    if count == 0 {
        anyhow::bail!("mode count must be at least 1");
    }
    let mut rows = Vec::new();
    let mut spacing = 0.0;
    for (i, modes) in files.iter().enumerate() {
        if modes.len() < count {
            anyhow::bail!(
                "recording {} has only {} modes, {count} needed",
                i + 1,
                modes.len()
            );
        }
        let mut m: Vec<Mode> = modes.clone();
        // Strongest by energy (level − 10·log10 decay), not onset level: a component that
        // dies within milliseconds (strike noise fitted as a mode) is not what rings.
        m.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
        m.truncate(count);
        let top = m.iter().map(|x| x.level_db).fold(f64::NEG_INFINITY, f64::max);
        m.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        let mut row = vec![0.0; 3 * count];
        for (k, md) in m.iter().enumerate() {
            row[k] = md.level_db - top;
            row[count + k] = match law {
                Some(law) => (md.decay_db_per_s.max(0.05) / law.decay_db_per_s(md.freq_hz).max(0.05)).ln(),
                None => md.decay_db_per_s.max(0.05).ln(),
            };
            row[2 * count + k] = md.freq_hz.log2();
        }
        spacing += spacing_octaves(m.iter().map(|x| x.freq_hz));
        rows.push(row);
    }
    let (mut mean, mut cov, _) = shrunk_covariance(&rows);
    if rows.iter().flatten().chain(&mean).any(|v| !v.is_finite()) {
        anyhow::bail!("a recording's modes are not finite numbers (level, decay or frequency)");
    }
    let top = mean[..count].iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    for v in &mut mean[..count] {
        *v += TOP_LEVEL_DB - top;
    }
    // One or two recordings say nothing about how objects of the family vary; the wider floor
    // keeps such draws from being copies of one recording.
    let floor = if files.len() < 3 { FEW_VAR_FLOOR } else { VAR_FLOOR };
    let floors: Vec<f64> = (0..3 * count).map(|i| floor[i / count]).collect();
    make_pd(&mut cov, &floors);
    Ok(ModeDistribution {
        count,
        gaussian: Gaussian {
            mean,
            covariance: cov,
        },
        mean_spacing_octaves: spacing / files.len() as f64,
        spacing_tolerance: 0.10,
        decay: if law.is_some() {
            DecayCoordinates::DampingResidual
        } else {
            DecayCoordinates::Absolute
        },
        rise_s: Vec::new(),
    })
}

/// Spread of the kernel around each recording in an exemplar mixture ([`fit_exemplar`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExemplarKernel {
    /// SD, octaves, of a shift common to all of an object's mode frequencies (a bigger or
    /// smaller object of the same kind), from [`size_bandwidth_octaves`].
    pub size_sd_octaves: f64,
}

/// Size coordinate of one recording: the energy-weighted mean log2 frequency of its `count`
/// strongest modes by energy.
fn size_log2(modes: &[Mode], count: usize) -> f64 {
    let mut m: Vec<&Mode> = modes.iter().collect();
    m.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
    m.truncate(count);
    let top = m.first().map_or(0.0, |x| energy_db(x));
    let (mut num, mut den) = (0.0, 0.0);
    for x in m {
        let w = 10f64.powf((energy_db(x) - top) / 10.0);
        num += w * x.freq_hz.log2();
        den += w;
    }
    num / den
}

/// Kernel bandwidth on the size coordinate (octaves) by Silverman's rule of thumb for a
/// one-dimensional kernel density estimate, `0.9 · min(SD, IQR/1.34) · n^(−1/5)` (Silverman
/// 1986, eq. 3.31): the recordings of one family are a sample of object sizes (a marimba's
/// bars span octaves), and a draw should be a new size between them, not only a copy of one.
/// 0 for fewer than 2 recordings (nothing says how sizes vary).
pub fn size_bandwidth_octaves(files: &[Vec<Mode>], count: usize) -> f64 {
    let mut v: Vec<f64> = files
        .iter()
        .map(|m| size_log2(m, count))
        .filter(|v| v.is_finite())
        .collect();
    let n = v.len();
    if n < 2 {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / n as f64;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    v.sort_by(f64::total_cmp);
    let q = |p: f64| {
        let x = p * (n - 1) as f64;
        let (i, f) = (x.floor() as usize, x.fract());
        v[i] + f * (v[(i + 1).min(n - 1)] - v[i])
    };
    let iqr = q(0.75) - q(0.25);
    let spread = if iqr > 0.0 { sd.min(iqr / 1.34) } else { sd };
    0.9 * spread * (n as f64).powf(-0.2)
}

/// One component of an exemplar (kernel) mixture: a Gaussian centred on ONE recording's modes
/// (its `count` strongest by energy, fewer if it has fewer, ordered by frequency), so a draw
/// keeps that object's modes together (its fundamental's level, decay and frequency stay one
/// mode's). The kernel: independent per-mode spreads of the few-recordings floors (~3 dB,
/// ~20 % decay, 0.05 octave: objects of one kind differ by a few per cent), plus a shift of
/// all frequencies together with SD `kernel.size_sd_octaves`. Levels normalised as in
/// [`fit_modes`], but by the strongest mode's envelope peak
/// ([`crate::engine::object::build_up_peak_factor`]); decays relative to `law` when given.
/// Returns the distribution and the level shift applied to this recording (for its transient).
/// Errors if fewer than 2 modes remain.
pub fn fit_exemplar(
    modes: &[Mode],
    count: usize,
    law: Option<&DampingModel>,
    kernel: ExemplarKernel,
) -> anyhow::Result<(ModeDistribution, f64)> {
    let mut m: Vec<Mode> = modes.to_vec();
    m.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
    m.truncate(count);
    let n = m.len();
    if n < 2 {
        anyhow::bail!("needs at least 2 modes, has {n}");
    }
    // Normalised by the top of each mode's envelope, not its onset level: a mode that builds up
    // never reaches its onset level (the fitted Steel Pan's drawn modes, summed at their
    // envelope tops, sit a median 14 dB under their onset levels' sum), and the strongest mode
    // as heard is what the engine's gain staging assumes.
    let top = m
        .iter()
        .map(|x| x.level_db + 20.0 * build_up_peak_factor(x.decay_db_per_s, x.attack_s).log10())
        .fold(f64::NEG_INFINITY, f64::max);
    m.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    let mut mean = vec![0.0; 3 * n];
    for (k, md) in m.iter().enumerate() {
        mean[k] = md.level_db - top + TOP_LEVEL_DB;
        mean[n + k] = match law {
            Some(law) => (md.decay_db_per_s.max(0.05) / law.decay_db_per_s(md.freq_hz).max(0.05)).ln(),
            None => md.decay_db_per_s.max(0.05).ln(),
        };
        mean[2 * n + k] = md.freq_hz.log2();
    }
    if mean.iter().any(|v| !v.is_finite()) {
        anyhow::bail!("a mode's level, decay or frequency is not a finite number");
    }
    let size_var = kernel.size_sd_octaves.powi(2);
    let mut cov = vec![vec![0.0; 3 * n]; 3 * n];
    for i in 0..3 * n {
        cov[i][i] = FEW_VAR_FLOOR[i / n];
    }
    for i in 2 * n..3 * n {
        for j in 2 * n..3 * n {
            cov[i][j] += size_var;
        }
    }
    Ok((
        ModeDistribution {
            count: n,
            gaussian: Gaussian {
                mean,
                covariance: cov,
            },
            mean_spacing_octaves: spacing_octaves(m.iter().map(|x| x.freq_hz)),
            spacing_tolerance: 0.10,
            decay: if law.is_some() {
                DecayCoordinates::DampingResidual
            } else {
                DecayCoordinates::Absolute
            },
            // Each mode's build-up as merged from its copies (`modes::consolidate_attack_free`);
            // none stored when no mode builds up, so such presets read as before.
            rise_s: if m.iter().any(|x| x.attack_s > 0.0) {
                m.iter().map(|x| x.attack_s).collect()
            } else {
                Vec::new()
            },
        },
        TOP_LEVEL_DB - top,
    ))
}

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
    let w = crate::fit::extract::hann(nw);
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
/// remove any). The decay is the line fit of that gap's dB track; the level makes the band
/// noise's total energy (whole signal, [`band_energies`]) equal to the gap's. Why not band
/// levels of the residual `y − modal` (the previous method): the residual also holds the modes'
/// misfit, which is as often excess as missing energy, and band noise fitted to it added that
/// misfit a second time (measured: docs/presets.md, resynthesis distance). `None` for bands
/// above 0.49·fs.
pub fn fit_transient_gap(y: &[f64], modal: &[f64], fs: f64) -> Vec<Option<(f64, f64)>> {
    fit_transient_gap_decaying(y, modal, fs, 0.0)
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
            let max_decay =
                20.0 * std::f64::consts::LOG10_E * std::f64::consts::PI * erb_bandwidth_hz(centres[band]);
            let decay = decay_from_track(&times, &l)
                .unwrap_or(1000.0)
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

/// Levenberg–Marquardt iterations of [`refit_transient_levels`] and [`refit_for_draws`].
const LEAKAGE_ITERATIONS: usize = 30;

/// Refits the transient bands' levels (decays kept) so that the modes' band energies `em` plus
/// the bands' *expected leaked* energies ([`transient_leakage`]) match the recording's `ey` in the
/// least-squares sense on the dB scale, over the bands within 60 dB of the recording's strongest.
/// `ey` and `em` are in the bands the recording is judged in (centres up to
/// [`analysis_high_hz`], those of [`erb_log_spectral_distance`]), not the transient's own: below
/// 35.6 kHz the two grids differ, and levels fitted in the transient's grid left the judged bands
/// of the 24–34 kHz recordings 1–2.5 dB further off (docs/presets.md). Why a refit: the first fit
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
/// fitted to the expected energy filled such bands and left each draw ±3–6 dB off; the mean over
/// draws weighs that spread against the gap the noise fills (docs/presets.md). Sample-average
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
            let Some(l) = crate::preset::cholesky(&g) else {
                lambda *= 10.0;
                continue;
            };
            let step = crate::preset::cholesky_solve(&l, &jtr);
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

/// Gaussian over `[α_0..α_N, ln β_0..ln β_N]` from per-recording band fits; missing bands are
/// imputed with the mean of the recordings that have them. Levels shifted by `level_shift_db`
/// (the same shift as the modes, so transient and modes keep their measured balance).
pub fn fit_transient_distribution(
    files: &[Vec<Option<(f64, f64)>>],
    level_shift: &[f64],
) -> TransientDistribution {
    let mut rows: Vec<Vec<f64>> = files
        .iter()
        .zip(level_shift)
        .map(|(f, s)| {
            let mut r = vec![f64::NAN; 2 * BANDS];
            for (i, b) in f.iter().enumerate() {
                if let Some((a, d)) = b {
                    r[i] = a + s;
                    r[BANDS + i] = d.ln();
                }
            }
            r
        })
        .collect();
    for j in 0..2 * BANDS {
        let have: Vec<f64> = rows.iter().map(|r| r[j]).filter(|v| v.is_finite()).collect();
        let fill = if have.is_empty() {
            if j < BANDS {
                -60.0
            } else {
                1000f64.ln()
            }
        } else {
            have.iter().sum::<f64>() / have.len() as f64
        };
        for r in &mut rows {
            if !r[j].is_finite() {
                r[j] = fill;
            }
        }
    }
    let (mean, mut cov, _) = if rows.len() >= 2 {
        shrunk_covariance(&rows)
    } else {
        (rows[0].clone(), vec![vec![0.0; 2 * BANDS]; 2 * BANDS], 1.0)
    };
    let floors: Vec<f64> = (0..2 * BANDS)
        .map(|i| if i < BANDS { 1.0 } else { 1e-3 })
        .collect();
    make_pd(&mut cov, &floors);
    TransientDistribution {
        bands: BANDS,
        low_hz: BAND_LOW_HZ,
        high_hz: BAND_HIGH_HZ,
        gaussian: Gaussian {
            mean,
            covariance: cov,
        },
    }
}

#[cfg(test)]
#[path = "distribution_tests.rs"]
mod tests;
