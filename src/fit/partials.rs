//! The ringing partials of an impact sound, read off the signal: the prominent peaks of its
//! early spectrum, each followed in time by a short-time DTFT at its frequency. One definition
//! serves both sides: a fit pools a recording's ringing modes from them
//! ([`crate::fit::pipeline::ringing_modes`]) and `tactus eval` measures T60, tan φ and the decay
//! slope on them ([`crate::eval::features`]), so the fit keeps what the evaluation hears. The
//! spectral centroid lives here for the same reason: the contact exponent's fit
//! ([`crate::fit::velocity`]) and the evaluation measure brightness alike.

use crate::fit::{extract, modes};
use realfft::RealFftPlanner;

/// Frequency band of the spectral peaks, Hz (upper end below the lowest recording Nyquist,
/// 10 kHz).
pub const PEAK_BAND_HZ: (f64, f64) = (50.0, 9_000.0);
/// Length of audio from the onset that the partials are followed over, s: one second holds
/// ≥ 12 dB of the decay of a partial with a 5 s T60 (the longest the recordings show, a ride
/// cymbal's bell) and the whole decay of most, enough to measure its rate.
pub const MODE_SPAN_S: f64 = 1.0;
/// Analysis window of the peak count, s (Blackman–Harris main lobe ±4 bins = ±16 Hz: partials a
/// semitone apart are resolved above ~300 Hz).
pub const PEAK_WINDOW_S: f64 = 0.25;
/// Peaks more than this far below the highest are not counted, dB.
pub const PEAK_RANGE_DB: f64 = 40.0;
/// Minimum prominence of a counted peak, dB (well above the Blackman–Harris side lobes' −92 dB
/// and the ripple of a decaying partial's skirt).
pub const PEAK_PROMINENCE_DB: f64 = 10.0;

/// The spectral peaks the features count in `y` (from its onset, at `fs`) and the partials they
/// follow there ([`partials`] at [`partial_peaks_hz`]): what [`sound_features`](crate::eval::features::sound_features) measures, and
/// what a fit pools as a recording's ringing modes.
pub fn peaks_and_partials(y: &[f64], fs: f64) -> (Vec<f64>, Vec<extract::Mode>) {
    let peaks_hz = spectral_peaks_hz(y, fs, PEAK_RANGE_DB, PEAK_PROMINENCE_DB);
    let modes = partials(y, fs, &partial_peaks_hz(y, fs, &peaks_hz));
    (peaks_hz, modes)
}

/// The frequencies whose [`partials`] the features follow, given the counted `peaks_hz` of `y`
/// (from its onset): those peaks, or for a sound with a single prominent peak, every spectral
/// maximum within [`LEAST_PARTIAL_RANGE_DB`] that stands [`LEAST_PARTIAL_PROMINENCE_DB`] out,
/// so that a nearly pure tone still has a second partial for the slope.
pub fn partial_peaks_hz(y: &[f64], fs: f64, peaks_hz: &[f64]) -> Vec<f64> {
    if peaks_hz.len() >= 2 {
        peaks_hz.to_vec()
    } else {
        spectral_peaks_hz(y, fs, LEAST_PARTIAL_RANGE_DB, LEAST_PARTIAL_PROMINENCE_DB)
    }
}

/// Samples per frame of the partials' tracks ([`partials`]) of a signal of `n` samples at `fs`:
/// [`PARTIAL_TRACK_FRAME_S`] rounded up to a power of two, shortened to half the tracked span
/// for a signal shorter than two frames (an 87 ms wood block still gives a track of several
/// frames).
pub fn partial_track_frame_len(fs: f64, n: usize) -> usize {
    let span = n.min((MODE_SPAN_S * fs) as usize);
    ((PARTIAL_TRACK_FRAME_S * fs) as usize)
        .next_power_of_two()
        .min(span / 2)
        .max(32)
}

/// Frequency resolution of the partials' tracks of a signal of `n` samples at `fs`, Hz: one
/// bin of their frames. Two components closer than this share one track.
pub fn partial_track_bin_hz(fs: f64, n: usize) -> f64 {
    fs / partial_track_frame_len(fs, n) as f64
}

/// Frame of the partials' short-time DTFT tracks, s (rounded to a power of two samples, as
/// the extractor's tracks): separates partials ~50 Hz apart and still gives a 0.1 s claves
/// hit several frames.
pub const PARTIAL_TRACK_FRAME_S: f64 = 0.04;
/// Frames per frame length: the hop is an eighth of a frame (5 ms), so a wood block's
/// partials, 60 dB in ~80 ms, are followed over a dozen points.
const TRACK_OVERLAP: usize = 8;

/// The partials of `y` (from its onset, at `fs`): one per spectral peak at `peaks_hz`, followed
/// over the first [`MODE_SPAN_S`] by a short-time DTFT evaluated exactly at the peak's
/// frequency (Hann frames of [`PARTIAL_TRACK_FRAME_S`]). A partial's decay is the extractor's line fit
/// of its dB track from the track's maximum down to its noise floor or a fade
/// ([`extract::decay_from_track`]); its energy is the track's. Returned as attack-free
/// [`extract::Mode`]s whose [`modes::energy_db`] orders them by that energy, strongest first;
/// peaks whose track does not decay are left out.
///
/// Why the signal and not the extracted components: the extractor models a swelling, beating
/// or two-stage decay by near-coincident copies of large, partly cancelling amplitudes and
/// fits the strike's broadband decay with components no listener hears as a ringing partial;
/// ranked by their own energy such components were the "strongest modes" (the fluidr3
/// marimbas' five strongest had T60s of 13–36 ms where their notes ring for over a second,
/// docs/evaluation.md). A prominent peak in the first quarter second is what rings.
pub fn partials(y: &[f64], fs: f64, peaks_hz: &[f64]) -> Vec<extract::Mode> {
    let n = y.len().min((MODE_SPAN_S * fs) as usize);
    let nw = partial_track_frame_len(fs, n);
    if n < 2 * nw {
        return Vec::new();
    }
    let hop = nw / TRACK_OVERLAP;
    let mut out: Vec<extract::Mode> = Vec::new();
    for &f in peaks_hz {
        let (t, power, _) = extract::dtft_track(&y[..n], fs, f, nw, hop);
        let energy: f64 = power.iter().sum();
        let l: Vec<f64> = power.iter().map(|p| 10.0 * (p + 1e-300).log10()).collect();
        let Some(decay) = extract::decay_from_track(&t, &l) else {
            continue;
        };
        if !(decay > 0.05 && energy > 0.0) {
            continue;
        }
        out.push(extract::Mode {
            freq_hz: f,
            level_db: 10.0 * energy.log10() + 10.0 * decay.log10(),
            decay_db_per_s: decay,
            phase: 0.0,
            attack_s: 0.0,
        });
    }
    out.sort_by(|a, b| modes::energy_db(b).total_cmp(&modes::energy_db(a)));
    out
}

/// Prominence and range (below the highest), dB, of the spectral maxima taken as partials when
/// fewer than two peaks reach [`PEAK_PROMINENCE_DB`] within [`PEAK_RANGE_DB`] (a nearly pure
/// tone: a marimba bar's fundamental can stand 40 dB above the rest). The slope needs two
/// partials; such a sound's second is its next maximum that stands out of the ripple of a
/// flat stretch of spectrum, however weak.
pub const LEAST_PARTIAL_PROMINENCE_DB: f64 = 3.0;
/// See [`LEAST_PARTIAL_PROMINENCE_DB`].
pub const LEAST_PARTIAL_RANGE_DB: f64 = 80.0;

/// Frequencies (Hz, ascending) of the spectral peaks of `y`: local maxima of the Blackman–Harris
/// magnitude spectrum of its first [`PEAK_WINDOW_S`] in [`PEAK_BAND_HZ`], within `range_db`
/// of the highest, with a topographic prominence of at least `prominence_db` (the peak count
/// takes [`PEAK_RANGE_DB`] and [`PEAK_PROMINENCE_DB`]).
pub fn spectral_peaks_hz(y: &[f64], fs: f64, range_db: f64, prominence_db: f64) -> Vec<f64> {
    let len = ((PEAK_WINDOW_S * fs) as usize).max(16);
    let seg = &y[..y.len().min(len)];
    // The window spans the analysis length even when the sound is shorter, so every sound is
    // seen at the same frequency resolution.
    let (a0, a1, a2, a3) = (0.35875, 0.48829, 0.14128, 0.01168);
    let nfft = (2 * len).next_power_of_two();
    let mut buf = vec![0.0; nfft];
    for (i, v) in seg.iter().enumerate() {
        let t = std::f64::consts::TAU * i as f64 / (len - 1) as f64;
        buf[i] = v * (a0 - a1 * t.cos() + a2 * (2.0 * t).cos() - a3 * (3.0 * t).cos());
    }
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let mut spec = fft.make_output_vec();
    if fft.process(&mut buf, &mut spec).is_err() {
        return Vec::new();
    }
    let bin_hz = fs / nfft as f64;
    let lo = (PEAK_BAND_HZ.0 / bin_hz).ceil() as usize;
    let hi = ((PEAK_BAND_HZ.1.min(0.49 * fs)) / bin_hz).floor() as usize;
    let db: Vec<f64> = spec[lo..=hi.min(spec.len() - 1)]
        .iter()
        .map(|c| 20.0 * c.norm().max(1e-300).log10())
        .collect();
    prominent_peaks(&db, range_db, prominence_db)
        .into_iter()
        .map(|i| (lo + i) as f64 * bin_hz)
        .collect()
}

/// Indices of the local maxima of `db` within `range_db` of the highest value whose
/// topographic prominence (height above the higher of the two lowest points between it and a
/// higher value on either side, or the array's end) is at least `prominence_db`.
pub fn prominent_peaks(db: &[f64], range_db: f64, prominence_db: f64) -> Vec<usize> {
    let top = db.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let n = db.len();
    let mut peaks = Vec::new();
    for i in 1..n.saturating_sub(1) {
        let v = db[i];
        if !(v > db[i - 1] && v >= db[i + 1]) || v < top - range_db {
            continue;
        }
        let mut left_min = v;
        for &w in db[..i].iter().rev() {
            if w > v {
                break;
            }
            left_min = left_min.min(w);
        }
        let mut right_min = v;
        for &w in &db[i + 1..] {
            if w > v {
                break;
            }
            right_min = right_min.min(w);
        }
        if v - left_min.max(right_min) >= prominence_db {
            peaks.push(i);
        }
    }
    peaks
}

/// Band of the spectral centroid, Hz: the peaks' band.
pub const CENTROID_BAND_HZ: (f64, f64) = PEAK_BAND_HZ;

/// Magnitude-spectrum centroid of `y` over [`CENTROID_BAND_HZ`] (clipped to 0.49·fs), Hz.
pub fn spectral_centroid(y: &[f64], fs: f64) -> Option<f64> {
    let nfft = (2 * y.len()).next_power_of_two().max(64);
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let mut buf = vec![0.0; nfft];
    buf[..y.len()].copy_from_slice(y);
    let mut spec = fft.make_output_vec();
    fft.process(&mut buf, &mut spec).ok()?;
    let bin = fs / nfft as f64;
    let (lo, hi) = (CENTROID_BAND_HZ.0, CENTROID_BAND_HZ.1.min(0.49 * fs));
    let (mut num, mut den) = (0.0, 0.0);
    for (k, c) in spec.iter().enumerate() {
        let f = k as f64 * bin;
        if f >= lo && f <= hi {
            let m = c.norm();
            num += f * m;
            den += m;
        }
    }
    (den > 0.0).then(|| num / den)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prominence_ignores_shoulders_and_far_peaks() {
        // Peak at 0 dB, a shoulder 3 dB above its valley, a real peak, one 50 dB down.
        let db = [-60.0, 0.0, -20.0, -17.0, -19.0, -40.0, -5.0, -60.0, -50.0, -70.0];
        assert_eq!(prominent_peaks(&db, 40.0, 10.0).len(), 2);
    }
}
