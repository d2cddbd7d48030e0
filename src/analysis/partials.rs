//! The ringing partials of an impact sound, read off the signal: the prominent peaks of its
//! early spectrum, each followed in time by a short-time DTFT at its frequency. One definition
//! serves both sides: a fit pools a recording's ringing modes from them
//! ([`crate::fit::recording::ringing_modes`]) and `tactus eval` measures T60, tan φ and the decay
//! slope on them ([`crate::analysis::features`]), so the fit keeps what the evaluation hears. The
//! spectral centroid lives here for the same reason: the contact exponent's fit
//! ([`crate::fit::pool::velocity`]) and the evaluation measure brightness alike.

use crate::analysis::signal::{self, energy_db, Mode};
use crate::engine::dsp::DB_PER_NEPER;
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
/// follow there ([`partials`] at [`partial_peaks_hz`]): what [`sound_features`](crate::analysis::features::sound_features) measures, and
/// what a fit pools as a recording's ringing modes.
pub fn peaks_and_partials(y: &[f64], fs: f64) -> (Vec<f64>, Vec<Mode>) {
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
/// frequency (Hann frames of [`PARTIAL_TRACK_FRAME_S`]). A partial's decay is read off its
/// track's energy from the track's maximum down to its noise floor ([`energy_decay_from_track`]);
/// its energy is the track's. Returned as attack-free
/// [`Mode`]s whose [`energy_db`] orders them by that energy, strongest first;
/// peaks whose track does not decay are left out.
///
/// Why the signal and not the extracted components: the extractor models a swelling, beating
/// or two-stage decay by near-coincident copies of large, partly cancelling amplitudes and
/// fits the strike's broadband decay with components no listener hears as a ringing partial;
/// ranked by their own energy such components were the "strongest modes" (the fluidr3
/// marimbas' five strongest had T60s of 13–36 ms where their notes ring for over a second,
/// docs/evaluation.md). A prominent peak in the first quarter second is what rings.
pub fn partials(y: &[f64], fs: f64, peaks_hz: &[f64]) -> Vec<Mode> {
    let n = y.len().min((MODE_SPAN_S * fs) as usize);
    let nw = partial_track_frame_len(fs, n);
    if n < 2 * nw {
        return Vec::new();
    }
    let hop = nw / TRACK_OVERLAP;
    let mut out: Vec<Mode> = Vec::new();
    for &f in peaks_hz {
        let (t, power, _) = signal::dtft_track(&y[..n], fs, f, nw, hop);
        let energy: f64 = power.iter().sum();
        let l: Vec<f64> = power.iter().map(|p| 10.0 * (p + 1e-300).log10()).collect();
        let Some(decay) = energy_decay_from_track(&t, &l) else {
            continue;
        };
        if !(decay > 0.05 && energy > 0.0) {
            continue;
        }
        out.push(Mode {
            freq_hz: f,
            level_db: 10.0 * energy.log10() + 10.0 * decay.log10(),
            decay_db_per_s: decay,
            phase: 0.0,
            attack_s: 0.0,
            ring: None,
        });
    }
    out.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
    out
}

/// The power track of `y`'s partial at `freq_hz` as [`partials`] follows it (frame centre
/// times s, power per frame); empty when `y` is shorter than two frames.
pub fn partial_track(y: &[f64], fs: f64, freq_hz: f64) -> (Vec<f64>, Vec<f64>) {
    let n = y.len().min((MODE_SPAN_S * fs) as usize);
    let nw = partial_track_frame_len(fs, n);
    if n < 2 * nw {
        return (Vec::new(), Vec::new());
    }
    let (t, power, _) = signal::dtft_track(&y[..n], fs, freq_hz, nw, nw / TRACK_OVERLAP);
    (t, power)
}

/// Build-up time constant τ (s) of an envelope `(1 − e^{−t/τ})·e^{−σt}` decaying at
/// `decay_db_per_s` that peaks at `peak_s`: `peak_s = τ·ln(1 + 1/(στ))`, solved for τ; at most
/// [`crate::preset::MAX_RISE_S`].
pub fn rise_for_peak(peak_s: f64, decay_db_per_s: f64) -> f64 {
    if !(peak_s > 0.0 && decay_db_per_s > 0.0) {
        return 0.0;
    }
    let sigma = decay_db_per_s / DB_PER_NEPER;
    let peak_at = |tau: f64| tau * (1.0 + 1.0 / (sigma * tau)).ln();
    let top = crate::preset::MAX_RISE_S;
    if peak_at(top) <= peak_s {
        return top;
    }
    // `peak_at` rises with τ: bisection in ln τ.
    let (mut lo, mut hi) = (1e-5f64.ln(), top.ln());
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if peak_at(mid.exp()) < peak_s {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    (0.5 * (lo + hi)).exp()
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

/// Half-width of the band around a partial whose energy is its ring, Hz: the partials of a
/// wood block or a cymbal come in clusters of modes 3–40 Hz apart that beat against each other
/// (docs/evaluation.md, "Features"); a band ±50 Hz wide holds such a cluster whole, so its
/// energy is one decaying energy. Bands of the strongest partials are kept at least two
/// half-widths apart, so no energy is read twice.
pub const BAND_HALF_WIDTH_HZ: f64 = 50.0;
/// Raised-cosine skirt of a band beyond its half-width, Hz: a brick-wall edge would ring in
/// time for as long as 1 / (its width) and smear the strike over the ring.
pub const BAND_SKIRT_HZ: f64 = 25.0;
/// Block of a band's power track, s: short beside the 10 ms attack window and the 60 ms EDT of
/// a wood block, so the early decay is read from several blocks.
pub const BAND_BLOCK_S: f64 = 0.002;
/// Longest stretch from the onset whose band energy is read, s: a ride cymbal's bell rings for
/// 5 s, and the recordings and draws are at most 10 s long.
pub const BAND_SPAN_S: f64 = 10.0;

/// The decay of the energy in the band around one partial ([`band_decays`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BandDecay {
    /// The partial at the band's centre, Hz.
    pub freq_hz: f64,
    /// The band's energy over the span (the signal's units squared × samples).
    pub energy: f64,
    /// Decay of the band's energy, dB/s ([`energy_decay_from_track`] on its power track).
    pub decay_db_per_s: f64,
    /// Early decay time of the band (ISO 3382: −60 dB over the slope of the band's Schroeder
    /// curve from the onset down to −10 dB), s.
    pub edt_s: f64,
}

/// Gain of the band centred on `fc` at `f` (both Hz): 1 within [`BAND_HALF_WIDTH_HZ`], a
/// raised-cosine skirt over [`BAND_SKIRT_HZ`] beyond.
pub fn band_gain(f: f64, fc: f64) -> f64 {
    let d = (f - fc).abs() - BAND_HALF_WIDTH_HZ;
    if d <= 0.0 {
        1.0
    } else if d < BAND_SKIRT_HZ {
        0.5 * (1.0 + (std::f64::consts::PI * d / BAND_SKIRT_HZ).cos())
    } else {
        0.0
    }
}

/// The energy decays of the bands around the strongest of `peaks_hz` in `y` (from its onset,
/// at `fs`), strongest band first, at most `count`: each band ([`BAND_HALF_WIDTH_HZ`]) is cut
/// out of `y`'s spectrum, its analytic signal's power summed over blocks of [`BAND_BLOCK_S`],
/// and that track's Schroeder integral read for the ring's decay
/// ([`energy_decay_from_track`]) and the early decay time. Bands that do not decay are left
/// out; a band within two half-widths of a stronger one is the same cluster and left out too.
///
/// Why a band and not the DTFT at the partial's frequency ([`partials`]): a cluster of modes
/// 20–40 Hz apart falls inside one ~40 ms frame's main lobe only in part, so the track at one
/// frequency beats and follows the strongest member's knock; the band holds the cluster's
/// energy, whose decay after the knock is the ring a listener hears.
pub fn band_decays(y: &[f64], fs: f64, peaks_hz: &[f64], count: usize) -> Vec<BandDecay> {
    let Some(mut bands) = BandTracks::new(y, fs) else {
        return Vec::new();
    };
    if peaks_hz.is_empty() || count == 0 {
        return Vec::new();
    }
    let mut ranked: Vec<(f64, f64)> = peaks_hz.iter().map(|&fc| (fc, bands.energy(fc))).collect();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut out: Vec<BandDecay> = Vec::new();
    for (fc, energy) in ranked {
        if out.len() >= count {
            break;
        }
        if !(energy > 0.0)
            || out
                .iter()
                .any(|b| (b.freq_hz - fc).abs() < 2.0 * BAND_HALF_WIDTH_HZ)
        {
            continue;
        }
        let Some((t, track, l)) = bands.track_db(fc) else {
            return Vec::new();
        };
        let (Some(decay), Some(edt_s)) = (
            energy_decay_from_track(&t, &l),
            early_decay_of_track(&t, &track, &l),
        ) else {
            continue;
        };
        if decay > 0.05 {
            out.push(BandDecay {
                freq_hz: fc,
                energy,
                decay_db_per_s: decay,
                edt_s,
            });
        }
    }
    out
}

/// The bands of one signal ([`BAND_HALF_WIDTH_HZ`] and its skirt around any centre), cut out
/// of its spectrum, which is computed once: their energies and power tracks in blocks of
/// [`BAND_BLOCK_S`] over at most [`BAND_SPAN_S`] from the signal's start.
pub struct BandTracks {
    n: usize,
    block: usize,
    fs: f64,
    bin_hz: f64,
    spec: Vec<realfft::num_complex::Complex<f64>>,
    inv: std::sync::Arc<dyn realfft::ComplexToReal<f64>>,
    band: Vec<realfft::num_complex::Complex<f64>>,
    out: Vec<f64>,
}

impl BandTracks {
    /// The bands of `y` (from its onset, at `fs`); `None` when it is shorter than 8 blocks.
    pub fn new(y: &[f64], fs: f64) -> Option<Self> {
        let n = y.len().min((BAND_SPAN_S * fs) as usize);
        let block = ((BAND_BLOCK_S * fs).round() as usize).max(1);
        if n < 8 * block {
            return None;
        }
        // Room after the signal for the band filters' tails, which would otherwise wrap round.
        let nfft = (n + (0.1 * fs) as usize).next_power_of_two();
        let mut planner = RealFftPlanner::<f64>::new();
        let fwd = planner.plan_fft_forward(nfft);
        let inv = planner.plan_fft_inverse(nfft);
        let mut buf = vec![0.0; nfft];
        buf[..n].copy_from_slice(&y[..n]);
        let mut spec = fwd.make_output_vec();
        fwd.process(&mut buf, &mut spec).ok()?;
        Some(Self {
            n,
            block,
            fs,
            bin_hz: fs / nfft as f64,
            band: inv.make_input_vec(),
            out: vec![0.0; nfft],
            spec,
            inv,
        })
    }

    fn bins(&self, fc: f64) -> std::ops::RangeInclusive<usize> {
        let lo = ((fc - BAND_HALF_WIDTH_HZ - BAND_SKIRT_HZ) / self.bin_hz)
            .floor()
            .max(1.0) as usize;
        let hi = (((fc + BAND_HALF_WIDTH_HZ + BAND_SKIRT_HZ) / self.bin_hz).ceil() as usize)
            .min(self.spec.len() - 2);
        lo..=hi
    }

    /// The energy of the band centred on `fc` Hz (the signal's units squared × samples, up to
    /// the transform's scale).
    pub fn energy(&self, fc: f64) -> f64 {
        self.bins(fc)
            .map(|k| self.spec[k].norm_sqr() * band_gain(k as f64 * self.bin_hz, fc).powi(2))
            .sum()
    }

    /// The power track of the band centred on `fc` Hz: its analytic signal's power, averaged
    /// over each block. `None` if the inverse transform fails.
    pub fn track(&mut self, fc: f64) -> Option<Vec<f64>> {
        // The band's signal and its Hilbert transform (the band's spectrum times −i): the sum of
        // their squares is the band's power without the ripple at twice its frequency.
        let mut power = vec![0.0; self.n];
        for quadrature in [false, true] {
            self.band.iter_mut().for_each(|c| *c = Default::default());
            for k in self.bins(fc) {
                let c = self.spec[k] * band_gain(k as f64 * self.bin_hz, fc);
                self.band[k] = if quadrature {
                    realfft::num_complex::Complex::new(c.im, -c.re)
                } else {
                    c
                };
            }
            self.inv.process(&mut self.band, &mut self.out).ok()?;
            for (p, v) in power.iter_mut().zip(&self.out) {
                *p += v * v;
            }
        }
        Some(
            power
                .chunks(self.block)
                .map(|c| c.iter().sum::<f64>() / c.len() as f64)
                .collect(),
        )
    }

    /// The power track of the band centred on `fc` Hz ([`BandTracks::track`]) with its block
    /// times ([`BandTracks::times`]) and its levels in dB: what a band's energy decay
    /// ([`energy_decay_from_track`]) is read from.
    pub fn track_db(&mut self, fc: f64) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>)> {
        let track = self.track(fc)?;
        let l = track.iter().map(|p| 10.0 * (p + 1e-300).log10()).collect();
        Some((self.times(track.len()), track, l))
    }

    /// The centre times (s from the signal's start) of the first `len` blocks.
    pub fn times(&self, len: usize) -> Vec<f64> {
        (0..len)
            .map(|k| (k as f64 + 0.5) * self.block as f64 / self.fs)
            .collect()
    }
}

/// Early decay time (ISO 3382), s, of a power track `power` (dB `l`) at block times `t` from
/// the onset: −60 dB over the slope of the least-squares line through its Schroeder curve
/// from the first block down to −10 dB, the curve integrated up to the last block above the
/// track's noise ([`ring_end`]) so that noise after the ring does not lengthen it.
fn early_decay_of_track(t: &[f64], power: &[f64], l: &[f64]) -> Option<f64> {
    let end = ring_end(l).filter(|&e| e >= 2)?;
    let mut edc = vec![0.0; end + 1];
    let mut acc = 0.0;
    for k in (0..=end).rev() {
        acc += power[k];
        edc[k] = acc;
    }
    if !(acc > 0.0) {
        return None;
    }
    // The first block at or under −10 dB closes the fit, so it spans at least two points.
    let stop = edc.iter().position(|&e| e <= 0.1 * acc).unwrap_or(end).max(1);
    let d: Vec<f64> = edc[..=stop]
        .iter()
        .map(|e| 10.0 * (e.max(1e-300) / acc).log10())
        .collect();
    let (slope, _) = signal::line_fit(&t[..=stop], &d);
    (slope < 0.0 && slope.is_finite()).then(|| -60.0 / slope)
}

/// Noise floor of a dB track above which [`energy_decay_from_track`] reads a decay: its 5th
/// percentile + 16 dB (as [`signal::decay_from_track`]).
fn usable_floor(l: &[f64]) -> f64 {
    let mut sorted = l.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[sorted.len() / 20] + 16.0
}

/// The last frame of a dB track above its [`usable_floor`], or its last frame when none is.
pub fn ring_end(l: &[f64]) -> Option<usize> {
    if l.is_empty() {
        return None;
    }
    let floor = usable_floor(l);
    Some(l.iter().rposition(|&v| v > floor).unwrap_or(l.len() - 1))
}

/// Least fall, dB, of a track that never reaches its noise over its span for
/// [`energy_decay_from_track`] to read it as decaying.
pub const MIN_DECAY_OVER_SPAN_DB: f64 = 6.0;

/// Decay (dB/s) of a partial's dB track `l` at frame times `t`, read off its energy: the
/// Schroeder backward integral of the track's power from its maximum to the last frame above
/// its noise floor, fitted by the integral of one exponential cut off there.
///
/// Why energy and not a line through the dB track: a cymbal's partial is a cluster of modes a
/// few hertz apart, and its track beats by ±10 dB. A line fitted from the track's maximum
/// follows the first beat down (200–1000 dB/s where the cluster's energy decays at 13–50 dB/s,
/// docs/evaluation.md) and stops at the first null. The backward integral sums the beats into
/// the cluster's energy, which decays at the rate its modes share; for a single exponential it
/// gives that exponential's rate, as the line does.
///
/// Why the cut-off exponential: the integral of a decay stopped at frame `E` is
/// `∝ e^{−βt} − e^{−βt_E}`, which bends down before `E` whatever `β`; fitting that shape, not a
/// line, reads `β` off the whole span. The span ends at the last frame above the floor (5th
/// percentile + 16 dB, as [`signal::decay_from_track`]); when the frames after it have stopped
/// decaying they are noise, and their mean power is subtracted from the span's before
/// integrating, so a partial that sinks into noise does not read as ringing on.
pub fn energy_decay_from_track(t: &[f64], l: &[f64]) -> Option<f64> {
    if t.len() < 3 || t.len() != l.len() {
        return None;
    }
    let top = l.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let k0 = l.iter().position(|&v| v == top)?;
    let usable_floor = usable_floor(l);
    // The last frame above the floor, not the first below it: a beating cluster's nulls dip
    // under the floor and the cluster rings on after them.
    // A track that spans less than that from its maximum to its lowest frame never reached
    // its noise (a partial ringing 10 dB/s over the one-second span): all of it is the decay,
    // if it decays at all (below).
    let (end, whole) = match (k0..l.len()).rev().find(|&k| l[k] > usable_floor) {
        Some(end) if end >= k0 + 2 => (end, false),
        _ => (l.len() - 1, true),
    };
    if end < k0 + 2 {
        return None;
    }
    let power: Vec<f64> = l.iter().map(|v| 10f64.powf(v / 10.0)).collect();
    let decay = integral_decay(t, &power, k0, end, 0.0)?;
    if whole {
        // Why at least 6 dB over the span: a crash cymbal's wash holds some peaks' tracks
        // level for the whole second while energy moves between its modes; read as a decay
        // they ring for minutes (Crash Cymbal draws with 20 s EDT against 2–6 s recorded).
        return (decay * (t[end] - t[k0]) >= MIN_DECAY_OVER_SPAN_DB).then_some(decay);
    }
    // The frames after the span are noise when they no longer decay (a quarter of the span's
    // rate or less); a track that ends above its noise keeps decaying there, and its "floor" is
    // its own tail, which must not be subtracted.
    let tail = end + 1..l.len();
    if tail.len() < 4 {
        return Some(decay);
    }
    let (slope, _) = signal::line_fit(&t[tail.clone()], &l[tail.clone()]);
    if -slope > 0.25 * decay {
        return Some(decay);
    }
    let noise = power[tail.clone()].iter().sum::<f64>() / tail.len() as f64;
    integral_decay(t, &power, k0, end, noise).or(Some(decay))
}

/// Power decay rate (dB/s) of `power` over frames `k0..=end` at times `t`, `noise` subtracted
/// from every frame: the least-squares fit, in `ln`, of the cut-off exponential's backward
/// integral to the track's ([`energy_decay_from_track`]).
fn integral_decay(t: &[f64], power: &[f64], k0: usize, end: usize, noise: f64) -> Option<f64> {
    let mut edc = vec![0.0; end - k0 + 1];
    let mut acc = 0.0;
    for k in (k0..=end).rev() {
        acc += power[k] - noise;
        edc[k - k0] = acc;
    }
    // The fit reads the integral's first 30 dB (ISO 3382's T30 span): further down it sums a
    // few noisy frames, whose logarithm would outweigh the decay. Where the noise subtraction
    // leaves the integral non-positive, the decay has ended.
    let n = edc
        .iter()
        .position(|&e| !(e > 1e-3 * edc[0]))
        .unwrap_or(edc.len());
    if n < 3 {
        return None;
    }
    let hop = (t[end] - t[k0]) / (end - k0) as f64;
    let ts: Vec<f64> = (0..n).map(|i| t[k0 + i] - t[k0]).collect();
    // The integral stops after frame `end`, wherever the fit stops reading it.
    let te = t[end] - t[k0] + hop;
    let ln_edc: Vec<f64> = edc[..n].iter().map(|e| e.ln()).collect();
    // Misfit for a power decay rate β (1/s); the offset is the mean residual.
    let cost = |ln_beta: f64| {
        let beta = ln_beta.exp();
        let model = |ti: f64| ((-beta * ti).exp() - (-beta * te).exp()).max(1e-300).ln();
        let c = ln_edc.iter().zip(&ts).map(|(a, &ti)| a - model(ti)).sum::<f64>() / n as f64;
        ln_edc
            .iter()
            .zip(&ts)
            .map(|(a, &ti)| (a - model(ti) - c).powi(2))
            .sum::<f64>()
    };
    // β between 0.01 dB/s (rings for hours) and 20 000 dB/s (3 ms T60), in nepers of power.
    let db_per_neper = 10.0 * std::f64::consts::LOG10_E;
    let ln_beta =
        signal::golden_section_min((0.01 / db_per_neper).ln(), (20_000.0 / db_per_neper).ln(), cost);
    Some(ln_beta.exp() * db_per_neper)
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

    /// A partial's track of `y` at `f`, as [`partials`] follows it.
    fn track(y: &[f64], fs: f64, f: f64) -> (Vec<f64>, Vec<f64>) {
        let nw = partial_track_frame_len(fs, y.len());
        let (t, p, _) = signal::dtft_track(y, fs, f, nw, nw / TRACK_OVERLAP);
        (t, p.iter().map(|p| 10.0 * (p + 1e-300).log10()).collect())
    }

    /// `Σ a·e^{−d·t/20·ln10}·sin(2πft)` over `(f, a, d dB/s)`, plus white noise of RMS `noise`.
    fn tones(fs: f64, secs: f64, parts: &[(f64, f64, f64)], noise: f64) -> Vec<f64> {
        let mut seed = 12345u64;
        (0..(secs * fs) as usize)
            .map(|i| {
                let t = i as f64 / fs;
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                parts
                    .iter()
                    .map(|&(f, a, d)| {
                        a * (-d * t / DB_PER_NEPER).exp() * (std::f64::consts::TAU * f * t).sin()
                    })
                    .sum::<f64>()
                    + noise * u * 12f64.sqrt()
            })
            .collect()
    }

    #[test]
    fn energy_decay_reads_one_exponential_into_noise() {
        let fs = 44_100.0;
        for decay in [20.0, 60.0, 300.0] {
            let y = tones(fs, 1.0, &[(1_000.0, 1.0, decay)], 1e-4);
            let (t, l) = track(&y, fs, 1_000.0);
            let got = energy_decay_from_track(&t, &l).unwrap();
            assert!((got / decay - 1.0).abs() < 0.05, "{decay} dB/s read as {got}");
            // The line fit agrees on a clean exponential.
            let line = signal::decay_from_track(&t, &l).unwrap();
            assert!((got / line - 1.0).abs() < 0.05, "energy {got}, line {line}");
        }
    }

    #[test]
    fn energy_decay_of_a_beating_pair_is_their_shared_rate() {
        // Two modes 3 Hz apart, one track: it beats by tens of dB, and the line from its
        // maximum follows the first beat down.
        let fs = 44_100.0;
        let y = tones(fs, 1.0, &[(2_000.0, 1.0, 30.0), (2_003.0, 0.8, 30.0)], 1e-5);
        let (t, l) = track(&y, fs, 2_001.5);
        let got = energy_decay_from_track(&t, &l).unwrap();
        assert!(
            (got / 30.0 - 1.0).abs() < 0.25,
            "beating pair at 30 dB/s read as {got}"
        );
    }

    /// The one band [`band_decays`] reads of `y` around `f` (asked for `peaks` in all).
    fn one_band(y: &[f64], fs: f64, peaks: &[f64]) -> BandDecay {
        let b = band_decays(y, fs, peaks, 5);
        assert_eq!(b.len(), 1, "{b:?}");
        b[0]
    }

    #[test]
    fn band_reads_one_exponential_into_noise() {
        let fs = 44_100.0;
        for decay in [20.0, 60.0, 300.0] {
            let y = tones(fs, 3.0, &[(1_000.0, 1.0, decay)], 1e-4);
            let b = one_band(&y, fs, &[1_000.0]);
            assert!(
                (b.decay_db_per_s / decay - 1.0).abs() < 0.05,
                "{decay} dB/s: {b:?}"
            );
            // One exponential: the early decay is the decay.
            assert!((b.edt_s * decay / 60.0 - 1.0).abs() < 0.1, "{decay} dB/s: {b:?}");
        }
    }

    #[test]
    fn band_of_a_beating_cluster_decays_at_its_energy_rate() {
        // A wood block's cluster: modes 25 and 30 Hz apart, beating as they ring at 100 dB/s.
        // The band holds the three as one energy (one band for three peaks), decaying at their
        // shared rate.
        let fs = 44_100.0;
        let y = tones(
            fs,
            2.0,
            &[
                (1_500.0, 1.0, 100.0),
                (1_525.0, 0.9, 100.0),
                (1_555.0, 0.7, 100.0),
            ],
            1e-5,
        );
        let b = one_band(&y, fs, &[1_500.0, 1_525.0, 1_555.0]);
        assert!((b.decay_db_per_s / 100.0 - 1.0).abs() < 0.1, "{b:?}");
        assert!((b.edt_s / 0.6 - 1.0).abs() < 0.2, "{b:?}");
        // A knock in the cluster (a loud member gone in 30 ms, holding as much energy as the
        // ring) barely moves the ring's rate, read from the band's maximum, and shortens the
        // early decay, read from the onset.
        let knocked = tones(
            fs,
            2.0,
            &[
                (1_500.0, 1.0, 100.0),
                (1_525.0, 0.9, 100.0),
                (1_540.0, 6.0, 2_000.0),
            ],
            1e-5,
        );
        let k = one_band(&knocked, fs, &[1_500.0, 1_525.0, 1_540.0]);
        assert!((k.decay_db_per_s / 100.0 - 1.0).abs() < 0.25, "{k:?}");
        assert!(k.edt_s < 0.9 * b.edt_s, "{k:?} vs {b:?}");
    }

    #[test]
    fn band_of_a_swelling_partial_rings_at_its_decay_and_decays_late() {
        // A partial building up over τ = 60 ms, then ringing at 40 dB/s (T60 1.5 s): the ring is
        // read from the band's maximum, and the early decay, read from the onset, is longer
        // than the ring's, as the energy first builds up.
        let fs = 44_100.0;
        let mut y = tones(fs, 4.0, &[(800.0, 1.0, 40.0)], 0.0);
        for (i, v) in y.iter_mut().enumerate() {
            *v *= 1.0 - (-(i as f64) / fs / 0.06).exp();
        }
        let b = one_band(&y, fs, &[800.0]);
        assert!((b.decay_db_per_s / 40.0 - 1.0).abs() < 0.1, "{b:?}");
        assert!(b.edt_s > 1.1 * 1.5 && b.edt_s < 3.0, "{b:?}");
    }

    #[test]
    fn bands_are_ranked_by_energy_and_read_once() {
        let fs = 44_100.0;
        // 500 Hz rings longest and holds most energy; 2 kHz is louder at first but short.
        let y = tones(
            fs,
            2.0,
            &[(500.0, 1.0, 30.0), (2_000.0, 2.0, 600.0), (2_040.0, 0.1, 600.0)],
            1e-5,
        );
        let b = band_decays(&y, fs, &[500.0, 2_000.0, 2_040.0], 5);
        assert_eq!(b.len(), 2, "{b:?}");
        assert_eq!((b[0].freq_hz, b[1].freq_hz), (500.0, 2_000.0), "{b:?}");
        assert!(band_decays(&y, fs, &[500.0, 2_000.0], 1).len() == 1);
        assert!(band_decays(&y[..100], fs, &[500.0], 5).is_empty());
    }

    /// [`rise_for_peak`] inverts the peak time of `(1 − e^{−t/τ})·e^{−σt}`, found on a fine
    /// grid of the envelope itself.
    #[test]
    fn rise_for_peak_inverts_the_envelope_peak() {
        for (tau, decay) in [(0.002, 300.0), (0.016, 40.0), (0.064, 8.0)] {
            let sigma: f64 = decay / DB_PER_NEPER;
            let env = |t: f64| (1.0 - (-t / tau).exp()) * (-sigma * t).exp();
            let dt = 1e-6;
            let peak = (1..2_000_000)
                .map(|i| i as f64 * dt)
                .max_by(|a, b| env(*a).total_cmp(&env(*b)))
                .unwrap();
            let read = rise_for_peak(peak, decay);
            assert!(
                (read / tau - 1.0).abs() < 1e-3,
                "τ {tau}: read {read} from a peak at {peak} s"
            );
        }
        assert_eq!(rise_for_peak(0.0, 20.0), 0.0);
        assert_eq!(rise_for_peak(0.05, 0.0), 0.0);
        assert_eq!(rise_for_peak(100.0, 1.0), crate::preset::MAX_RISE_S);
    }
}
