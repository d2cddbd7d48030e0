//! Baseline mode extractor: Traer et al.'s iterative spectrogram matching (Traer, Cusimano &
//! McDermott 2019 §2.1), kept to compare against the shipped extractor ([`crate::fit::recording::extract`])
//! on synthetic ground truth and on the recordings (docs/presets.md, "Extraction on synthetic ground truth", says
//! which one ships and why).
//!
//! The published procedure, per mode, 15 times: (1) take the spectrogram channel of maximum
//! power; (2) start a decaying sinusoid there; (3) adjust its frequency, onset power and decay to
//! minimise the mean-squared error between the spectrograms of the recording and of the
//! synthetic; (4) subtract the synthetic spectrogram from the recording's and repeat.
//!
//! What the paper leaves open and this implementation chooses:
//!
//! - **Spectrogram**: power STFT, Hann window of ~46 ms (a power of two in samples), hop a
//!   quarter window, ×2 zero padding, frames from the onset ([`signal::onset_and_dc`], the same
//!   t = 0 as the shipped extractor) to the end of the file.
//! - **Error**: squared difference of the dB spectrograms, floored 90 dB below the recording's
//!   strongest cell (a power-domain error is decided by the first frames alone and cannot see
//!   the decay), over the starting channel's main lobe without its nulls (±3 bins; at the nulls, ±4, the dB
//!   error is decided by the ignored image phase) and all frames, clipped at
//!   ±15 dB per cell, against the synthetic plus a noise floor (a fourth fitted parameter, one
//!   power per cell). Without the floor term and the clip, the noise and a fade-out gate
//!   set the decay.
//! - A channel within the main lobe of a mode already fitted is not started from again: the
//!   residual a one-mode-at-a-time fit leaves there would otherwise be picked every time.
//! - **Synthetic spectrogram** of `A·e^{−αt}·cos(ωt)`: frame `m` at `s_m` is
//!   `A²·e^{−2α s_m/fs}·|G(k)|²`, `G` the windowed spectrum of the first frame (exact for the
//!   positive-frequency part; the image at −f is included through the real FFT).
//! - **Search**: Nelder–Mead over (frequency in bins, level dB, ln decay, noise dB), started from
//!   the channel's parabolic peak, its first-frame level and the slope of its dB track.
//! - Subtraction in power, clipped at the floor. Phases are not observable in a power
//!   spectrogram: modes come out with phase 0.

use crate::analysis::signal::{self, Mode};
use crate::engine::dsp::DB_PER_NEPER;
use crate::fit::pool::damping::nelder_mead;
use crate::fit::recording::extract::Extraction;
use realfft::RealFftPlanner;
use std::sync::Arc;

/// Modes Traer et al. extract per recording.
pub const TRAER_MODES: usize = 15;

/// Channels either side of the starting channel that the error is taken over.
const REGION_BINS: usize = 3;

/// Spectrogram window, s (rounded up to a power of two in samples). Measured on the synthetic
/// ground truth with an earlier variant (no noise term): 23, 46, 90 and 180 ms left mean decay
/// errors of 50, 32, 31 and 29 % at 44.1 kHz; the window is not what limits the method.
const WINDOW_S: f64 = 0.046;

/// Largest per-cell dB error counted (see the error in [`extract_traer`]).
const CLIP_DB: f64 = 15.0;

/// Floor of the dB spectrograms, below the recording's strongest cell.
const FLOOR_DB: f64 = 90.0;

struct Spectrogram {
    nw: usize,
    nfft: usize,
    hop: usize,
    fs: f64,
    /// `power[m][k]`, frames × (nfft/2 + 1).
    power: Vec<Vec<f64>>,
    window: Vec<f64>,
    fft: Arc<dyn realfft::RealToComplex<f64>>,
}

impl Spectrogram {
    fn new(y: &[f64], fs: f64) -> Option<Self> {
        let nw = ((WINDOW_S * fs) as usize).next_power_of_two().max(64);
        let nfft = 2 * nw;
        let hop = nw / 4;
        if y.len() < nw {
            return None;
        }
        let window = signal::hann(nw);
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(nfft);
        let mut buf = vec![0.0; nfft];
        let mut spec = fft.make_output_vec();
        let mut power = Vec::new();
        let mut s = 0;
        while s + nw <= y.len() {
            buf.iter_mut().for_each(|v| *v = 0.0);
            for i in 0..nw {
                buf[i] = y[s + i] * window[i];
            }
            fft.process(&mut buf, &mut spec).ok()?;
            power.push(spec.iter().map(|c| c.norm_sqr()).collect());
            s += hop;
        }
        Some(Self {
            nw,
            nfft,
            hop,
            fs,
            power,
            window,
            fft,
        })
    }

    fn bin_hz(&self) -> f64 {
        self.fs / self.nfft as f64
    }

    /// `|G(k)|²` of the first frame of a unit-amplitude mode (frequency `f` Hz, amplitude decay
    /// `alpha` 1/s); the frame starting at `s` samples is this times `e^{−2α s/fs}`.
    fn mode_shape(&self, f: f64, alpha: f64) -> Vec<f64> {
        let mut buf: Vec<f64> = (0..self.nw)
            .map(|n| {
                let t = n as f64 / self.fs;
                self.window[n] * (-alpha * t).exp() * (std::f64::consts::TAU * f * t).cos()
            })
            .collect();
        buf.resize(self.nfft, 0.0);
        let mut spec = self.fft.make_output_vec();
        self.fft.process(&mut buf, &mut spec).expect("fft sizes match");
        spec.iter().map(|c| c.norm_sqr()).collect()
    }

    /// Subtracts a mode (frequency `f` Hz, level dB re full-scale amplitude, decay dB/s) from
    /// the power spectrogram, frames at the times `frame_t`, clipping at zero power.
    fn subtract_mode(&mut self, f: f64, level_db: f64, decay: f64, frame_t: &[f64]) {
        let alpha = decay / DB_PER_NEPER;
        let shape = self.mode_shape(f, alpha);
        let amp2 = 10f64.powf(level_db / 10.0);
        let bins = self.nfft / 2 + 1;
        for (m, row) in self.power.iter_mut().enumerate() {
            let g = amp2 * (-2.0 * alpha * frame_t[m]).exp();
            for k in 0..bins {
                row[k] = (row[k] - g * shape[k]).max(0.0);
            }
        }
    }
}

/// Offset (bins, within ±½) of the maximum of the parabola through three dB values around a
/// peak; 0 where they do not curve down.
fn parabolic_peak(a: f64, b: f64, c: f64) -> f64 {
    let den = a - 2.0 * b + c;
    if den < 0.0 {
        (0.5 * (a - c) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

/// −slope (dB/s) of the least-squares line through the dB `track` at the frame times `t`; 0 with
/// fewer than two points or a flat time axis.
fn falling_slope(t: &[f64], track: &[f64]) -> f64 {
    let usable = t.len();
    if usable < 2 {
        return 0.0;
    }
    let (tm, vm) = (
        t.iter().sum::<f64>() / usable as f64,
        track.iter().sum::<f64>() / usable as f64,
    );
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for i in 0..usable {
        sxy += (t[i] - tm) * (track[i] - vm);
        sxx += (t[i] - tm).powi(2);
    }
    if sxx > 0.0 {
        -sxy / sxx
    } else {
        0.0
    }
}

/// Extracts up to `max_modes` modes by Traer et al.'s iterative spectrogram matching (module
/// docs). Modes are returned strongest (onset level) first, phase 0.
pub fn extract_traer(x: &[f64], fs: f64, max_modes: usize) -> Extraction {
    let (onset, dc) = signal::onset_and_dc(x);
    let y: Vec<f64> = x[onset..].iter().map(|v| v - dc).collect();
    // Traer's model has no attack term.
    let mut out = Extraction {
        modes: Vec::new(),
        onset,
        dc,
        attack_s: 0.0,
    };
    let Some(mut sg) = Spectrogram::new(&y, fs) else {
        return out;
    };
    let frames = sg.power.len();
    let bins = sg.nfft / 2 + 1;
    let peak = sg.power.iter().flatten().cloned().fold(0.0f64, f64::max);
    if !(peak > 0.0) {
        return out;
    }
    let floor = peak * 10f64.powf(-FLOOR_DB / 10.0);
    let db = |p: f64| 10.0 * (p.max(0.0) + floor).log10();
    let bin_hz = sg.bin_hz();
    let frame_t: Vec<f64> = (0..frames).map(|m| (m * sg.hop) as f64 / fs).collect();
    let top_bin = ((0.49 * fs) / bin_hz) as usize;
    let mut used: Vec<usize> = Vec::new();
    let max_ln_decay = (60.0 * fs / sg.nw as f64).ln();
    for _ in 0..max_modes {
        // (1) The channel of maximum power (summed over frames), away from DC and Nyquist.
        let lo = 2;
        let hi = top_bin.min(bins - 2);
        if hi <= lo {
            break;
        }
        let chan: Vec<f64> = (0..bins)
            .map(|k| sg.power.iter().map(|row| row[k]).sum::<f64>())
            .collect();
        let taken = |k: usize| used.iter().any(|&u: &usize| k.abs_diff(u) <= REGION_BINS);
        let Some(k0) = (lo..hi)
            .filter(|&k| !taken(k))
            .max_by(|&a, &b| chan[a].total_cmp(&chan[b]))
        else {
            break;
        };
        if !(chan[k0] > floor * frames as f64 * 10.0) {
            break;
        }
        // (2) Start: parabolic peak of the channel powers in dB, first-frame level, dB slope.
        let delta = parabolic_peak(db(chan[k0 - 1]), db(chan[k0]), db(chan[k0 + 1]));
        let f_start = (k0 as f64 + delta) * bin_hz;
        let track: Vec<f64> = sg.power.iter().map(|row| db(row[k0])).collect();
        let usable = track
            .iter()
            .position(|&v| v < db(0.0) + 10.0)
            .unwrap_or(frames)
            .max(2)
            .min(frames);
        let slope = falling_slope(&frame_t[..usable], &track[..usable]);
        // Power dB/s → amplitude dB/s is the same number (both 10·log10 of power per second
        // = 20·log10 of amplitude per second).
        let decay_start = slope.clamp(1.0, 0.9 * max_ln_decay.exp());
        let shape0 = sg.mode_shape(f_start, decay_start / DB_PER_NEPER);
        // Level = 20·log10 A = first-frame power dB − the unit mode's dB at the channel.
        let level_start = track[0] - 10.0 * shape0[k0].max(1e-300).log10();
        let r0 = k0.saturating_sub(REGION_BINS).max(1);
        let r1 = (k0 + REGION_BINS).min(bins - 1);
        // Noise floor: a fourth parameter, one power per cell over the region (the recording's
        // noise is in every frame, the synthetic's is not), started 10 dB under the channel's
        // 20th-percentile power.
        let noise_start = {
            let mut v: Vec<f64> = sg.power.iter().map(|row| row[k0]).collect();
            v.sort_by(f64::total_cmp);
            db(v[v.len() / 5]) - 10.0
        };
        // (3) Nelder–Mead on the dB spectrogram error over the region.
        let mut cost = |p: &[f64]| -> f64 {
            let f = p[0] * bin_hz;
            // Bounds: within 30 dB of the starting level; decays from 0.01 dB/s up to a fall of
            // 60 dB across one window (≈ 1300 dB/s at 46 ms): faster ones are not resolved by
            // the spectrogram, and a fit left free there traded level against decay on the onset
            // cells (measured: +17 dBFS at 4000 dB/s on a steel drum).
            if !(f > 0.0 && f < 0.5 * fs)
                || !((p[1] - level_start).abs() <= 30.0)
                || !(p[2] > -4.6 && p[2] < max_ln_decay)
                || !(p[3] <= track[0])
            {
                return f64::INFINITY;
            }
            let alpha = p[2].exp() / DB_PER_NEPER;
            let shape = sg.mode_shape(f, alpha);
            let amp2 = 10f64.powf(p[1] / 10.0);
            let noise = 10f64.powf(p[3] / 10.0);
            let mut e = 0.0;
            for (m, row) in sg.power.iter().enumerate() {
                let g = amp2 * (-2.0 * alpha * frame_t[m]).exp();
                for k in r0..=r1 {
                    // Clipped at CLIP_DB: a gate or fade-out drops the recording's cells to the
                    // floor, and an unclipped dB error would let those frames set the decay.
                    let d = (db(row[k]) - db(g * shape[k] + noise)).clamp(-CLIP_DB, CLIP_DB);
                    e += d * d;
                }
            }
            e
        };
        // Two rounds, the second restarted from the first's best with smaller steps (a
        // collapsed simplex stalls Nelder–Mead short of the minimum).
        let p = nelder_mead(
            &mut cost,
            &[f_start / bin_hz, level_start, decay_start.ln(), noise_start],
            &[0.3, 3.0, 0.4, 6.0],
            300,
            0.0,
        );
        let p = nelder_mead(&mut cost, &p, &[0.05, 0.5, 0.1, 3.0], 300, 0.0);
        // p[1] is 20·log10 A: the level in dB re full scale amplitude.
        let (f, level_db, decay) = (p[0] * bin_hz, p[1], p[2].exp());
        // (4) Subtract the fitted mode's spectrogram from the recording's.
        sg.subtract_mode(f, level_db, decay, &frame_t);
        used.push(k0);
        out.modes.push(Mode {
            freq_hz: f,
            level_db,
            decay_db_per_s: decay,
            phase: 0.0,
            attack_s: 0.0,
            ring: None,
        });
    }
    out.modes.sort_by(|a, b| b.level_db.total_cmp(&a.level_db));
    out
}
