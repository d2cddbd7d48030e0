//! Pooling fitted recordings of one material into a mode distribution (docs/model.md §3,
//! Traer et al. 2019 §2.1 eq. 4): a multivariate Gaussian over `[levels dB, ln decay dB/s,
//! log2 Hz]` of each recording's strongest modes ordered by frequency rank, with
//! Schäfer–Strimmer/Ledoit–Wolf shrinkage of the correlations toward zero (target "diagonal,
//! unequal variances") because there are fewer recordings than parameters. The noise-band
//! transient pooled beside it is [`crate::fit::recording::transient`].

use crate::analysis::signal::energy_db;
use crate::analysis::signal::Mode;
use crate::engine::object::{build_up_peak_factor, spacing_octaves};
use crate::fit::recording::bands::{BANDS, BAND_HIGH_HZ, BAND_LOW_HZ};
use crate::preset::{
    DampingModel, DecayCoordinates, Gaussian, ModeDistribution, ModeRing, TransientDistribution,
    MIN_LAW_DECAY_DB_PER_S,
};

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
    /// The preset's contact stiffness, N/m, and Hunt–Crossley exponent the strike is for.
    pub stiffness_n_per_m: f64,
    /// See [`ContactCompensation::stiffness_n_per_m`].
    pub exponent: f64,
}

impl ContactCompensation {
    /// The engine's default strike (default settings' mass, hardness and contact model, 1 m/s)
    /// on a preset of contact stiffness `stiffness_n_per_m` and exponent `exponent`.
    pub fn default_strike(stiffness_n_per_m: f64, exponent: f64) -> Self {
        use crate::engine::force::{ImpactForce, ImpactParams};
        let s = crate::engine::Settings::default().impact;
        let mut force = ImpactForce::default();
        force.start(
            &ImpactParams {
                hc_exponent: exponent,
                ..ImpactParams::new(s.mass_kg, 1.0, stiffness_n_per_m * s.hardness, s.contact_model)
            },
            192_000.0,
        );
        Self {
            duration_s: force.duration_s(),
            stiffness_n_per_m,
            exponent,
        }
    }

    /// What the default strike's contact envelope takes from a mode at `freq_hz`, dB:
    /// `10·log10(1 + (2fτ)⁴)`, uncapped (the engine's contact is not capped; the boost is).
    pub fn envelope_loss_db(&self, freq_hz: f64) -> f64 {
        let x = 2.0 * freq_hz * self.duration_s;
        let b = 10.0 * (1.0 + x.powi(4)).log10();
        if b.is_finite() {
            b.max(0.0)
        } else {
            0.0
        }
    }

    /// Boost in dB at `freq_hz`: the envelope loss ([`Self::envelope_loss_db`]) it makes up,
    /// at most [`MAX_CONTACT_BOOST_DB`].
    pub fn boost_db(&self, freq_hz: f64) -> f64 {
        self.envelope_loss_db(freq_hz).min(MAX_CONTACT_BOOST_DB)
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

pub(crate) fn make_pd(cov: &mut [Vec<f64>], floors: &[f64]) {
    let p = cov.len();
    for i in 0..p {
        cov[i][i] = cov[i][i].max(floors[i]);
    }
    // Shrink the off-diagonal further until Cholesky succeeds (always does at 0).
    let mut k = 0;
    while crate::engine::dsp::linalg::cholesky(cov).is_none() && k < 60 {
        for i in 0..p {
            for j in 0..p {
                if i != j {
                    cov[i][j] *= 0.8;
                }
            }
        }
        k += 1;
    }
    if crate::engine::dsp::linalg::cholesky(cov).is_none() {
        for i in 0..p {
            for j in 0..p {
                if i != j {
                    cov[i][j] = 0.0;
                }
            }
        }
    }
}

/// The decay block's coordinate of `md`: `ln b`, or with a damping `law` its deviation from the
/// law at its frequency ([`DecayCoordinates::DampingResidual`]), both floored as a draw reads them.
fn decay_coordinate(md: &Mode, law: Option<&DampingModel>) -> f64 {
    let b = md.decay_db_per_s.max(MIN_LAW_DECAY_DB_PER_S);
    match law {
        Some(law) => (b / law.residual_base_db_per_s(md.freq_hz)).ln(),
        None => b.ln(),
    }
}

/// Fits the mode distribution from per-recording modes. `count` modes per object (each
/// recording's `count` strongest by energy, sorted by frequency; pass modes through
/// [`crate::fit::recording::modes::consolidate`] first). Levels are normalised per recording to
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
            row[count + k] = decay_coordinate(md, law);
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
        rings: Vec::new(),
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
    // never reaches its onset level (docs/model.md, "Loudness of a drawn object"), and the
    // strongest mode as heard is what the engine's gain staging assumes.
    let top = m
        .iter()
        .map(|x| x.level_db + 20.0 * build_up_peak_factor(x.decay_db_per_s, x.attack_s).log10())
        .fold(f64::NEG_INFINITY, f64::max);
    m.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    let mut mean = vec![0.0; 3 * n];
    for (k, md) in m.iter().enumerate() {
        mean[k] = md.level_db - top + TOP_LEVEL_DB;
        mean[n + k] = decay_coordinate(md, law);
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
            // Each mode's ring (`ring::fit_rings`) with its decay relative to the mode's, so it
            // follows the drawn decay; none stored when no mode rings.
            rings: if m.iter().any(|x| x.ring.is_some()) {
                m.iter().map(mode_ring).collect()
            } else {
                Vec::new()
            },
        },
        TOP_LEVEL_DB - top,
    ))
}

/// A fitted mode's ring as a preset stores it ([`ModeRing`]): none without one, or when its
/// decay is not below the mode's.
fn mode_ring(m: &Mode) -> ModeRing {
    match m.ring {
        Some(r) if r.decay_db_per_s < m.decay_db_per_s && m.decay_db_per_s > 0.0 => ModeRing {
            share: r.share.min(crate::preset::MAX_RING_SHARE),
            decay_ratio: r.decay_db_per_s / m.decay_db_per_s,
        },
        _ => ModeRing::default(),
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
