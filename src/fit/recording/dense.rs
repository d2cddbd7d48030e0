//! Fitting the dense mode field of a recording (docs/model.md, "Dense mode field";
//! [`crate::preset::DenseField`]): the spectral peaks that `tactus eval` counts
//! ([`partials::peaks_and_partials`]) beyond those the component's own modes cover, per
//! third-octave band: how many, how loud relative to the component's strongest mode, how fast
//! they decay (their DTFT partial tracks, [`partials::partials`]).
//!
//! Why peaks and not extracted components: the extractor keeps at most
//! [`extract::MAX_MODES`] components, where a cymbal's first quarter second shows 180–200
//! prominent peaks; the peaks are what a listener (and the peak count) hears as its density.

use crate::analysis::partials;
use crate::analysis::signal::{energy_db, Mode};
use crate::engine::dsp::DB_PER_NEPER;
use crate::fit::recording::level_for_energy;

/// Third-octave bands of the field: edges at `DENSE_LOW_HZ · 2^(k/3)`, up to the top of the
/// peak count's band ([`partials::CENTROID_BAND_HZ`]), where the peaks are measured.
pub const DENSE_LOW_HZ: f64 = 50.0;

/// A recording gets a dense field only when its counted peaks number at least this many times
/// the component's modes: below it, the fitted modes already hold most of what rings (a bar,
/// a bell, a wood block), and a few drawn extra modes would only blur its own.
pub const DENSE_MIN_PEAK_RATIO: f64 = 2.0;

/// Bands whose peaks are fewer than this take their level and decay laws from all the
/// recording's uncovered peaks (a mean and SD of one or two values say little).
pub const MIN_PEAKS_FOR_BAND_LAWS: usize = 4;

/// Smallest level SD of a band, dB, and smallest `ln` decay SD: the spread of a band's
/// peaks is measured with the tracks' errors in it, but a single-valued law would draw every
/// dense mode of the band alike.
pub const MIN_LEVEL_SD_DB: f64 = 1.0;
/// See [`MIN_LEVEL_SD_DB`].
pub const MIN_LN_DECAY_SD: f64 = 0.05;

/// What a recording offers a dense field: its counted peaks and the partials tracked at them,
/// with onset levels ([`onset_levels`]).
#[derive(Debug, Clone, Default)]
pub struct Candidates {
    /// Number of peaks the peak count finds ([`partials::spectral_peaks_hz`]).
    pub peaks: usize,
    /// The partials at those peaks that decay, levels as onset levels in dB re full scale.
    pub partials: Vec<Mode>,
    /// Sample rate, Hz, and samples from the onset of the recording.
    pub fs: f64,
    /// See [`Candidates::fs`].
    pub n: usize,
    /// Per [`band_edges`] band, the build-up time τ of its partials, s ([`band_build_ups`]).
    pub band_rises: Vec<f64>,
    /// The recording's attack share ([`crate::analysis::features::attack_share`]): the build-ups
    /// are kept where they bring the drawn component nearer it ([`calibrate_family`]).
    pub attack_share: f64,
}

/// The [`Candidates`] of `y` (from its onset, at `fs`), from its peaks and the `measured`
/// partials at them ([`partials::peaks_and_partials`]), with onset levels and their bands'
/// build-ups ([`band_build_ups`]).
pub fn candidates(peaks: usize, measured: &[Mode], y: &[f64], fs: f64) -> Candidates {
    let partials = onset_levels(measured, &band_energy_decays(measured, y, fs), fs, y.len());
    Candidates {
        peaks,
        band_rises: band_build_ups(&partials, y, fs),
        partials,
        fs,
        n: y.len(),
        attack_share: crate::analysis::features::attack_share(y, fs),
    }
}

impl Candidates {
    /// The candidate partial `p` swelling with its band's build-up ([`Candidates::band_rises`]),
    /// its level raised to keep the energy it has without ([`build_up_level_db`]).
    pub fn swelling(&self, p: &Mode) -> Mode {
        let rise = self.band_rises.get(band_of(p.freq_hz)).copied().unwrap_or(0.0);
        Mode {
            level_db: p.level_db + build_up_level_db(p.decay_db_per_s, rise),
            attack_s: rise,
            ..*p
        }
    }
}

/// Index of the [`band_edges`] band holding `freq_hz` (the first or last band outside them).
pub(crate) fn band_of(freq_hz: f64) -> usize {
    let edges = band_edges();
    edges
        .windows(2)
        .position(|e| freq_hz < e[1])
        .unwrap_or(edges.len() - 2)
}

/// Per [`band_edges`] band: the build-up time τ (s) of `partials` in it, from the frame at which
/// the sum of their power tracks ([`partials::partial_track`]) peaks, with their median decay
/// ([`partials::rise_for_peak`]); 0 where the sum is highest in its first frame (the band starts
/// at full level, or peaks within half a frame, ~20 ms). Why the band's sum and not each
/// partial's track: neighbouring partials ~50 Hz apart beat within one track, so one track's
/// maximum falls anywhere, and their median over-reads the build-up (docs/fit-alternatives.md); the sum averages the beats out. Why at all: a
/// cymbal's partials swell after the strike as the vibration spreads from its low modes to its
/// high ones (the forzee china's envelope stays within 3 dB of its maximum for ~120 ms), and a
/// dense mode that starts at full level puts that energy into the first milliseconds.
pub fn band_build_ups(partials: &[Mode], y: &[f64], fs: f64) -> Vec<f64> {
    let bands = band_edges().len() - 1;
    let mut sums: Vec<Vec<f64>> = vec![Vec::new(); bands];
    let mut decays: Vec<Vec<f64>> = vec![Vec::new(); bands];
    let mut times = Vec::new();
    for p in partials {
        let (t, power) = partials::partial_track(y, fs, p.freq_hz);
        if power.is_empty() {
            return vec![0.0; bands];
        }
        let b = band_of(p.freq_hz);
        if sums[b].is_empty() {
            sums[b] = vec![0.0; power.len()];
        }
        for (s, v) in sums[b].iter_mut().zip(&power) {
            *s += v;
        }
        decays[b].push(p.decay_db_per_s);
        times = t;
    }
    sums.iter()
        .zip(&decays)
        .map(|(s, d)| {
            let k = (0..s.len()).max_by(|&a, &b| s[a].total_cmp(&s[b]));
            match k {
                Some(k) if k > 0 => partials::rise_for_peak(times[k], crate::stats::median(d)),
                _ => 0.0,
            }
        })
        .collect()
}

/// dB to add to the onset level of a mode decaying at `decay_db_per_s` that builds up with
/// time constant `rise_s`, for it to keep the energy it has without the build-up:
/// `∫e^{−2σt} / ∫(1 − e^{−t/τ})²·e^{−2σt}`.
pub(crate) fn build_up_level_db(decay_db_per_s: f64, rise_s: f64) -> f64 {
    if !(rise_s > 0.0 && decay_db_per_s > 0.0) {
        return 0.0;
    }
    let s2 = 2.0 * decay_db_per_s / DB_PER_NEPER;
    let r = 1.0 / rise_s;
    let free = 1.0 / s2;
    let built = 1.0 / s2 - 2.0 / (s2 + r) + 1.0 / (s2 + 2.0 * r);
    let db = 10.0 * (free / built).log10();
    if db.is_finite() {
        db
    } else {
        0.0
    }
}

/// The decay of the energy in each of `measured`'s bands ([`partials::BandTracks`], the band
/// the evaluation's T60 reads, over up to [`partials::BAND_SPAN_S`] of `y`), in dB/s; `None`
/// where the band does not decay.
///
/// Why the band and not the partial's own track: the tracks span the first
/// [`partials::MODE_SPAN_S`], where a cymbal's energy is still moving between its modes (the
/// wash spreading from the strike), so a dense partial's track reads slower or faster than the
/// ring that follows, and beats with its neighbours within a bin. Drawn at those decays, the
/// Crash Cymbal's components each rang 1.0–2.8 times their own recordings' T60 and 1.6 times
/// their EDT in the median (`tactus eval --components`). The band holds the partial and its
/// neighbours over the whole ring, the energy whose decay a listener hears and the evaluation
/// measures.
pub fn band_energy_decays(measured: &[Mode], y: &[f64], fs: f64) -> Vec<Option<f64>> {
    let Some(mut bands) = partials::BandTracks::new(y, fs) else {
        return vec![None; measured.len()];
    };
    measured
        .iter()
        .map(|p| {
            let (t, _, l) = bands.track_db(p.freq_hz)?;
            partials::energy_decay_from_track(&t, &l).filter(|d| *d > 0.0 && d.is_finite())
        })
        .collect()
}

/// `measured` partials ([`partials::partials`], whose `level_db` only orders by energy) with
/// their `decays` where given ([`band_energy_decays`]) and onset levels: the level at which a
/// mode of that decay gives the partial's track energy in a signal of `n` samples
/// ([`level_for_energy`], as the pooled modes get theirs).
pub fn onset_levels(measured: &[Mode], decays: &[Option<f64>], fs: f64, n: usize) -> Vec<Mode> {
    measured
        .iter()
        .zip(decays.iter().chain(std::iter::repeat(&None)))
        .filter_map(|(p, d)| {
            let m = Mode {
                level_db: 0.0,
                decay_db_per_s: d.unwrap_or(p.decay_db_per_s),
                ..*p
            };
            let level_db = level_for_energy(&m, p.freq_hz, energy_db(p), fs, n)?;
            level_db.is_finite().then_some(Mode { level_db, ..m })
        })
        .collect()
}

/// The band edges, Hz: third octaves from [`DENSE_LOW_HZ`] to the top of the peak band.
pub fn band_edges() -> Vec<f64> {
    let top = partials::CENTROID_BAND_HZ.1;
    let mut e: Vec<f64> = (0..)
        .map(|k| DENSE_LOW_HZ * 2f64.powf(k as f64 / 3.0))
        .take_while(|&f| f < top)
        .collect();
    e.push(top);
    e
}

/// The partials of `c` that none of `own` covers: those more than one track bin
/// ([`partials::partial_track_bin_hz`]) from every one of its modes. Why one bin: a peak within
/// it of one of the component's modes is that mode.
pub fn uncovered<'a>(c: &'a Candidates, own: &'a [Mode]) -> impl Iterator<Item = &'a Mode> {
    let bin = partials::partial_track_bin_hz(c.fs, c.n);
    c.partials
        .iter()
        .filter(move |p| own.iter().all(|m| (m.freq_hz - p.freq_hz).abs() > bin))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pair of modes 12 Hz apart beats within one partial track; their band's energy decays
    /// at the rate they share, over the whole ring.
    #[test]
    fn band_energy_decay_is_the_rings_over_the_whole_span() {
        let fs = 44_100.0;
        let n = (6.0 * fs) as usize;
        let mode = |freq_hz: f64, level_db: f64| Mode {
            freq_hz,
            level_db,
            decay_db_per_s: 15.0,
            phase: 0.0,
            attack_s: 0.0,
            ring: None,
        };
        let pair = [mode(3000.0, 0.0), mode(3012.0, -2.0)];
        let mut y = crate::fit::recording::extract::synthesize(&pair, fs, n);
        // A floor 100 dB under the onset, as a recording has one.
        let mut state = 1u64;
        for v in y.iter_mut() {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            *v += 1e-5 * ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5);
        }
        let measured = [Mode {
            freq_hz: 3000.0,
            decay_db_per_s: 90.0,
            ..pair[0]
        }];
        let d = band_energy_decays(&measured, &y, fs)[0].expect("the band decays");
        assert!((d - 15.0).abs() < 1.0, "{d} dB/s");
    }
}
