//! The ring after the knock (docs/model.md "Ring"): where a partial's band rings on long after
//! the partial's own fitted decay, that mode decays in two stages, fitted to its band's energy
//! over the whole ring.

use crate::analysis::partials::{self, BandTracks, BAND_HALF_WIDTH_HZ};
use crate::analysis::signal::{energy_db, golden_section_min, two_stage_energy, Mode, Ring};
use crate::engine::dsp::DB_PER_NEPER;
use crate::fit::recording::modes::{build_up_energy_db, build_up_energy_integral, MAX_FIT_RISE_S};
use crate::preset::MAX_RING_SHARE;
use realfft::num_complex::Complex;

/// A band rings on after its mode's knock when its fitted ring decays at most this fraction of
/// the mode's rate: closer than that, one exponential explains the band as well.
const RING_RATIO: f64 = 0.67;

/// Share below which a fitted ring is left out: at 0.5 % of the onset amplitude (−46 dB) it
/// rings under the knock and the strike noise for the whole span a listener hears it in.
const MIN_RING_SHARE: f64 = 0.005;

/// Ring and swell decays [`fit_band`] tries, log-spaced between 1/40 of the mode's and
/// [`RING_RATIO`] of it.
const DECAY_STEPS: usize = 32;

/// Depth of the band's Schroeder curve the fit compares, dB ([`fit_band`]).
const EDC_RANGE_DB: f64 = 50.0;

/// A band whose Schroeder curve its mode's one stage fits within 1 dB rms (the mean squared
/// error of [`fit_band`], dB²) rings as its mode: a ring would fit the fit's own errors.
const ONE_STAGE_ERROR_DB2: f64 = 1.0;

/// Per mode of `modes` (a recording's ringing modes, strongest first, as `ringing_modes` returns
/// them) the ring or swell its band shows in `y` (from the onset, at `fs`), or `None`. Modes
/// that build up are left as they are unless `swells`.
///
/// Each band ([`BAND_HALF_WIDTH_HZ`] around a mode) is given to its strongest mode; the modes
/// in it and the candidate's two-stage decay make a model of the band's energy, whose Schroeder
/// curve (normalised to its onset) is fitted in dB to the band's measured one from the onset to
/// the last block above the band's noise or [`EDC_RANGE_DB`] down, over the ring's share (up to
/// [`MAX_RING_SHARE`]) and decay. A preset mode may build up or ring, not both, so a mode that
/// builds up gets the better of a swell fitted to the band ([`BandFit::Swell`]) and a ring
/// without its build-up ([`BandFit::Ring`]), its energy kept either way ([`with_rings`]). Why
/// not always: in a recording with many partials beside its modes (a cymbal's) a band's decay is
/// theirs as much as the mode's, and a cymbal so refitted rang several times as long as its
/// recording (docs/model.md "Swelling modes").
///
/// Why the whole curve and not its first instants: the joint fit explains the waveform's first
/// milliseconds, where the knock dominates, so a wood block's bands decay at 540–1480 dB/s in
/// its modes and at 133–294 dB/s in the recording after the knock. Why a share of the mode and
/// not a mode of its own at the band's rate: pooled and drawn on its own, such a ring mode is
/// drawn without its knock, and a band that holds only a ring has the ring's early decay.
pub fn fit_rings(modes: &[Mode], y: &[f64], fs: f64, swells: bool) -> Vec<Option<BandFit>> {
    let mut out = vec![None; modes.len()];
    let Some(mut bands) = BandTracks::new(y, fs) else {
        return out;
    };
    let mut order: Vec<usize> = (0..modes.len()).collect();
    order.sort_by(|&a, &b| energy_db(&modes[b]).total_cmp(&energy_db(&modes[a])));
    let mut claimed: Vec<f64> = Vec::new();
    for i in order {
        let m = &modes[i];
        if claimed
            .iter()
            .any(|&c| (c - m.freq_hz).abs() <= BAND_HALF_WIDTH_HZ)
        {
            continue;
        }
        claimed.push(m.freq_hz);
        if !(m.decay_db_per_s > 0.0) || (m.attack_s > 0.0 && !swells) {
            continue;
        }
        let Some(track) = bands.track(m.freq_hz) else {
            continue;
        };
        let others: Vec<(f64, f64, f64)> = modes
            .iter()
            .enumerate()
            .filter(|&(j, o)| j != i && (o.freq_hz - m.freq_hz).abs() <= BAND_HALF_WIDTH_HZ)
            .map(|(_, o)| {
                (
                    10f64.powf(o.level_db / 10.0),
                    neper(o.decay_db_per_s),
                    o.freq_hz - m.freq_hz,
                )
            })
            .collect();
        out[i] = fit_band(m, &others, &track, &bands.times(track.len()));
    }
    out
}

/// What a mode's band shows beyond the mode's own fitted decay ([`fit_rings`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BandFit {
    /// The mode rings on after its knock; a mode that built up no longer does, its energy kept
    /// ([`with_rings`]): a swell starts with none of the burst a band may show at the strike.
    Ring(Ring),
    /// A mode that builds up swells and decays as its band does: its decay (dB/s) and build-up
    /// time (s), to replace the mode's own, its energy kept ([`with_rings`]).
    ///
    /// Why: the joint fit explains a swelling partial's first instants, where a steel drum's
    /// partials are fitted as short swells decaying several times faster than their bands do
    /// over the whole ring.
    Swell {
        /// The mode's decay, dB/s.
        decay_db_per_s: f64,
        /// The mode's build-up time constant, s.
        attack_s: f64,
    },
}

/// Amplitude decay, dB/s → nepers per second.
fn neper(db_per_s: f64) -> f64 {
    db_per_s / DB_PER_NEPER
}

/// The ring of `m` that best fits the band power `track` at block times `t`, beside the band's
/// `others` (onset power, nepers/s, offset from `m` in Hz), or `None` when none fits with a share
/// of at least [`MIN_RING_SHARE`]; for a mode that builds up, that ring or the swell
/// ([`fit_swell`]) that fits best, or `None` when its own shape fits best.
///
/// The model's band power is computed through the band's own filter ([`BandTracks`]: a gain
/// over frequency, zero phase), in closed form per exponential: the analytic signal
/// `e^{(−σ + iω₀)t}` for `t ≥ 0` has the spectrum `1/(σ + i2π(f − f₀))`, so the band passes
/// `∫ G(f)·e^{i2π(f − f₀)t}/(σ + i2π(f − f₀)) df` (a build-up is the difference of two such
/// exponentials). Why: the band's filter spans ~10 ms and smears a knock of 700 dB/s over its
/// first blocks; compared with unfiltered exponentials, the fit read that smear as ring and
/// overestimated the share by a third.
fn fit_band(m: &Mode, others: &[(f64, f64, f64)], track: &[f64], t: &[f64]) -> Option<BandFit> {
    let l: Vec<f64> = track.iter().map(|p| 10.0 * (p + 1e-300).log10()).collect();
    let end = partials::ring_end(&l)?;
    // Compared down to −50 dB of the Schroeder curve: below, the band filter's own tail (its
    // response to the strike's step) is as loud as what is left of a fast knock, and the
    // closed form and the FFT's filter differ there by several dB.
    let end = normalised_edc_db(&track[..=end])
        .iter()
        .position(|&v| v < -EDC_RANGE_DB)
        .unwrap_or(end)
        .min(end);
    if end < 8 {
        return None;
    }
    // The blocks the curves are compared at: every one of the first 64, then at most 192
    // more evenly spread, each standing for the blocks up to the next (a cymbal's 5 s ring
    // is 2500 blocks).
    let stride = (end.saturating_sub(64)).div_ceil(192).max(1);
    let at: Vec<usize> = (0..=end.min(64))
        .chain((64 + stride..=end).step_by(stride))
        .collect();
    let weight: Vec<f64> = at
        .iter()
        .enumerate()
        .map(|(j, &k)| (at.get(j + 1).copied().unwrap_or(end + 1) - k) as f64)
        .collect();
    let full = normalised_edc_db(&track[..=end]);
    let measured: Vec<f64> = at.iter().map(|&k| full[k]).collect();
    // The early decay (to −10 dB) weighs as much as the ring after it, though it spans a few
    // blocks against hundreds: both are heard (EDT and T60).
    let early = measured
        .iter()
        .position(|&v| v <= -10.0)
        .unwrap_or(at.len() - 1)
        .clamp(1, at.len() - 1);
    let filter = BandFilter::new(&at.iter().map(|&k| t[k]).collect::<Vec<_>>(), t[end] + 0.1);
    let sk = neper(m.decay_db_per_s);
    let background: Vec<f64> = (0..at.len())
        .map(|j| {
            others
                .iter()
                .map(|&(e, s, df)| e * filter.response(s, df)[j].norm_sqr())
                .sum::<f64>()
        })
        .collect();
    let mut model = vec![0.0; at.len()];
    // The error in dB² of the band's Schroeder curve with the mode's band response `a` at
    // onset power `g2`: the early decay and the rest weighted alike.
    let mut error = |g2: f64, a: &dyn Fn(usize) -> Complex<f64>| {
        for (j, p) in model.iter_mut().enumerate() {
            *p = (g2 * a(j).norm_sqr() + background[j]) * weight[j];
        }
        let d: Vec<f64> = normalised_edc_db(&model)
            .iter()
            .zip(&measured)
            .map(|(a, b)| (a - b).powi(2))
            .collect();
        d[..early].iter().sum::<f64>() / early as f64
            + d[early..].iter().sum::<f64>() / (d.len() - early).max(1) as f64
    };
    // Ring decays, or a swell's decays, from 1/40 of the mode's up to RING_RATIO of it,
    // log-spaced.
    let slower =
        |k: usize| sk * RING_RATIO * (1.0f64 / 40.0 / RING_RATIO).powf(k as f64 / (DECAY_STEPS - 1) as f64);
    let g2 = 10f64.powf(m.level_db / 10.0);
    let energy = g2 * build_up_energy_integral(sk, m.attack_s);
    let knock = filter.response(sk, 0.0);
    let own = if m.attack_s > 0.0 {
        let late = filter.response(sk + 1.0 / m.attack_s, 0.0);
        error(g2, &|j| knock[j] - late[j])
    } else {
        error(g2, &|j| knock[j])
    };
    if own < ONE_STAGE_ERROR_DB2 {
        return None;
    }
    // A knock and its ring, by golden section on the share for each ring decay. A mode that
    // builds up is tried without its build-up, its energy kept: a swell cannot start with the
    // burst a band may show at the strike before it rings on.
    let mut ring_best = (own, 0.0, sk);
    for k in 0..DECAY_STEPS {
        let sr = slower(k);
        let ring = filter.response(sr, 0.0);
        let onset = |s: f64| {
            if m.attack_s > 0.0 {
                energy / ring_energy_integral(s, sk, sr)
            } else {
                g2
            }
        };
        let mut cost = |s: f64| error(onset(s), &|j| knock[j] * (1.0 - s) + ring[j] * s);
        let share = golden_section_min(0.0, MAX_RING_SHARE, &mut cost);
        let e = cost(share);
        if e < ring_best.0 {
            ring_best = (e, share, sr);
        }
    }
    let (ring_error, share, sr) = ring_best;
    let ring = (share >= MIN_RING_SHARE).then_some(BandFit::Ring(Ring {
        share,
        decay_db_per_s: sr * DB_PER_NEPER,
    }));
    if m.attack_s <= 0.0 {
        return ring;
    }
    let swell = fit_swell(m, energy, &filter, |g2, a| error(g2, a), &slower);
    match (ring, swell) {
        (Some(r), Some((e, _))) if ring_error <= e => Some(r),
        (_, Some((e, s))) if e < own => Some(s),
        (r, _) => r,
    }
}

/// `∫₀^∞ ((1 − s)·e^{−σt} + s·e^{−σ_r t})² dt`: the energy of a mode with a ring (share `s`,
/// decays σ and σ_r in 1/s) per unit squared onset amplitude.
fn ring_energy_integral(share: f64, sigma: f64, sigma_ring: f64) -> f64 {
    let k = sigma.max(1e-9);
    two_stage_energy(share, k, sigma_ring.max(1e-9)) / (2.0 * k)
}

/// Build-up times [`fit_swell`] tries, as multiples of the mode's own.
const SWELL_RISE_FACTORS: [f64; 5] = [0.25, 0.5, 1.0, 2.0, 4.0];

/// The decay and build-up time of a mode `m` that builds up whose band fits the measured one
/// best (`error` of a mode's onset power and band response), over the decays
/// `slower(0..DECAY_STEPS)`
/// and the mode's build-up time scaled by [`SWELL_RISE_FACTORS`] (at most
/// [`MAX_FIT_RISE_S`]), with its error; `None` when none decays slower than the mode's own.
/// The mode keeps its `energy` (onset power × [`build_up_energy_integral`]; the Schroeder
/// curve is normalised, so only the band's other modes make it matter).
fn fit_swell(
    m: &Mode,
    energy: f64,
    filter: &BandFilter,
    mut error: impl FnMut(f64, &dyn Fn(usize) -> Complex<f64>) -> f64,
    slower: &dyn Fn(usize) -> f64,
) -> Option<(f64, BandFit)> {
    let sk = neper(m.decay_db_per_s);
    let mut best: Option<(f64, f64, f64)> = None;
    for k in 0..DECAY_STEPS {
        let sigma = slower(k);
        let direct = filter.response(sigma, 0.0);
        for f in SWELL_RISE_FACTORS {
            let tau = (m.attack_s * f).min(MAX_FIT_RISE_S);
            let late = filter.response(sigma + 1.0 / tau, 0.0);
            let g2 = energy / build_up_energy_integral(sigma, tau);
            let e = error(g2, &|j| direct[j] - late[j]);
            if best.is_none_or(|b| e < b.0) {
                best = Some((e, sigma, tau));
            }
        }
    }
    let (e, sigma, tau) = best?;
    (sigma < sk).then_some((
        e,
        BandFit::Swell {
            decay_db_per_s: sigma * DB_PER_NEPER,
            attack_s: tau,
        },
    ))
}

/// The band filter of [`BandTracks`] around a mode, as the closed-form response of one-sided
/// exponentials at chosen times ([`fit_band`]).
struct BandFilter {
    /// Frequency offsets from the band's centre, Hz.
    df: Vec<f64>,
    /// Per time, per offset: `G(f)·e^{i2π·df·t}·Δf`.
    kernel: Vec<Vec<Complex<f64>>>,
}

impl BandFilter {
    /// The filter at times `t` (s), its frequency grid fine enough (`1/span`) that the
    /// response does not wrap round within `span` s.
    fn new(t: &[f64], span: f64) -> Self {
        let reach = BAND_HALF_WIDTH_HZ + partials::BAND_SKIRT_HZ;
        let step = 1.0 / span;
        let n = (2.0 * reach / step).ceil() as usize + 1;
        let df: Vec<f64> = (0..n).map(|q| -reach + q as f64 * step).collect();
        let kernel = t
            .iter()
            .map(|&tj| {
                df.iter()
                    .map(|&d| {
                        Complex::from_polar(
                            partials::band_gain(d, 0.0) * step,
                            std::f64::consts::TAU * d * tj,
                        )
                    })
                    .collect()
            })
            .collect();
        Self { df, kernel }
    }

    /// The band's analytic output at each time for `e^{(−σ + i2π(f₀ + offset))t}`, `t ≥ 0`
    /// (σ in nepers/s, `offset` Hz from the band's centre).
    fn response(&self, sigma: f64, offset: f64) -> Vec<Complex<f64>> {
        let spectrum: Vec<Complex<f64>> = self
            .df
            .iter()
            .map(|&d| Complex::new(sigma, std::f64::consts::TAU * (d - offset)).inv())
            .collect();
        self.kernel
            .iter()
            .map(|row| row.iter().zip(&spectrum).map(|(k, x)| k * x).sum())
            .collect()
    }
}

/// Schroeder curve of a power track in dB re its value at the first block.
fn normalised_edc_db(power: &[f64]) -> Vec<f64> {
    let mut edc = vec![0.0; power.len()];
    let mut acc = 0.0;
    for (e, p) in edc.iter_mut().zip(power).rev() {
        acc += p;
        *e = acc;
    }
    let top = edc.first().copied().unwrap_or(1.0).max(1e-300);
    edc.iter().map(|e| 10.0 * (e.max(1e-300) / top).log10()).collect()
}

/// `modes` with the rings and, if `swells`, the swells [`fit_rings`] finds for them in `y` (from
/// the onset, at `fs`); a mode that builds up keeps its energy ([`build_up_energy_db`]).
pub fn with_rings(mut modes: Vec<Mode>, y: &[f64], fs: f64, swells: bool) -> Vec<Mode> {
    let fits = fit_rings(&modes, y, fs, swells);
    for (m, fit) in modes.iter_mut().zip(fits) {
        let Some(fit) = fit else { continue };
        let built_up = m.attack_s > 0.0;
        let before = build_up_energy_db(m);
        match fit {
            BandFit::Ring(r) => {
                m.ring = Some(r);
                m.attack_s = 0.0;
            }
            BandFit::Swell {
                decay_db_per_s,
                attack_s,
            } => {
                m.decay_db_per_s = decay_db_per_s;
                m.attack_s = attack_s;
            }
        }
        // A ring added to a mode that starts at full level keeps its onset amplitude (docs/model.md
        // "Ring"); a mode that built up keeps its energy instead.
        if built_up {
            m.level_db += before - build_up_energy_db(m);
        }
    }
    modes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::recording::extract::synthesize;

    fn mode(freq_hz: f64, level_db: f64, decay_db_per_s: f64, ring: Option<Ring>) -> Mode {
        Mode {
            freq_hz,
            level_db,
            decay_db_per_s,
            phase: 0.4,
            attack_s: 0.0,
            ring,
        }
    }

    /// Adds a noise floor 80 dB under the tests' onsets (deterministic, from `seed`), so a ring
    /// ends somewhere.
    fn add_noise_floor(y: &mut [f64], seed: u64) {
        let mut state = seed;
        for v in y.iter_mut() {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            *v += 1e-4 * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
        }
    }

    /// A knock with a ring under it, beside a plain mode in another band: the fit finds the
    /// ring's share and decay from the band's energy, and no ring where the band has none.
    #[test]
    fn fits_the_ring_under_a_knock_and_none_where_there_is_none() {
        let fs = 44_100.0;
        let truth = Ring {
            share: 0.1,
            decay_db_per_s: 140.0,
        };
        let modes = [
            mode(700.0, -6.0, 700.0, Some(truth)),
            mode(1900.0, -10.0, 900.0, None),
        ];
        let mut y = synthesize(&modes, fs, (0.6 * fs) as usize);
        add_noise_floor(&mut y, 1);
        let knocks: Vec<Mode> = modes.iter().map(|m| Mode { ring: None, ..*m }).collect();
        let rings = fit_rings(&knocks, &y, fs, true);
        let Some(BandFit::Ring(r)) = rings[0] else {
            panic!("the 700 Hz band rings: {:?}", rings[0]);
        };
        println!("fitted share {:.3}, decay {:.1} dB/s", r.share, r.decay_db_per_s);
        assert!((r.share / truth.share - 1.0).abs() < 0.25, "share {}", r.share);
        assert!(
            (r.decay_db_per_s / truth.decay_db_per_s - 1.0).abs() < 0.2,
            "decay {}",
            r.decay_db_per_s
        );
        assert_eq!(
            rings[1], None,
            "the 1900 Hz band decays as its mode: {:?}",
            rings[1]
        );
    }

    /// A swell that rings long, given as the joint fit gives it (a short swell), and a burst
    /// with a ring under it, given as a mode that builds up: the first gets its band's decay as
    /// a swell, the second its ring without the build-up, both keeping their energy; neither
    /// when swells are not asked for.
    #[test]
    fn a_mode_that_builds_up_swells_or_rings_as_its_band_does() {
        let fs = 44_100.0;
        let swell = Mode {
            attack_s: 0.02,
            ..mode(800.0, -6.0, 80.0, None)
        };
        let burst = mode(
            1500.0,
            -6.0,
            700.0,
            Some(Ring {
                share: 0.1,
                decay_db_per_s: 100.0,
            }),
        );
        let mut y = synthesize(&[swell, burst], fs, fs as usize);
        add_noise_floor(&mut y, 7);
        let given = [
            Mode {
                decay_db_per_s: 600.0,
                ..swell
            },
            Mode {
                attack_s: 0.002,
                ring: None,
                ..burst
            },
        ];
        let energy = |m: &Mode| {
            let k = neper(m.decay_db_per_s);
            let e = match m.ring {
                Some(r) => ring_energy_integral(r.share, k, neper(r.decay_db_per_s)),
                None => build_up_energy_integral(k, m.attack_s),
            };
            10.0 * m.level_db.mul_add(0.1, e.log10())
        };
        let fitted = with_rings(given.to_vec(), &y, fs, true);
        assert_eq!(
            with_rings(given.to_vec(), &y, fs, false),
            given,
            "no swells asked for"
        );
        println!("{fitted:?}");
        let (s, b) = (&fitted[0], &fitted[1]);
        assert!(s.ring.is_none() && s.attack_s > 0.0, "{s:?}");
        assert!(
            (s.decay_db_per_s / 80.0 - 1.0).abs() < 0.2,
            "swell decay {}",
            s.decay_db_per_s
        );
        assert!(
            (energy(s) - energy(&given[0])).abs() < 1e-9,
            "swell's energy kept"
        );
        let r = b.ring.expect("the burst rings");
        assert_eq!(b.attack_s, 0.0, "a ringing mode does not build up");
        assert!((r.share / 0.1 - 1.0).abs() < 0.3, "share {}", r.share);
        assert!(
            (r.decay_db_per_s / 100.0 - 1.0).abs() < 0.25,
            "ring decay {}",
            r.decay_db_per_s
        );
        assert!(
            (energy(b) - energy(&given[1])).abs() < 1e-9,
            "burst's energy kept"
        );
    }
}
