//! Modal resonator bank (MODEL.md §1–2, Traer eq. 2): each mode is a complex one-pole
//! `z[n] = p·z[n−1] + g·x[n]`, `p = exp(−d + iω)`, output `Re z`. An impulse gives exactly
//! `g·e^{−dn}·cos(ωn)`, Traer's damped cosine. Struct of arrays, fixed capacity + active count.
//!
//! PROVISIONAL scalar implementation: the API is the contract; the SIMD kernel and drift
//! renormalisation replace the internals.

/// Highest mode frequency kept, as a fraction of the sample rate.
pub const MAX_FREQ_FRACTION: f64 = 0.49;

/// One mode's target parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeParams {
    /// Frequency in Hz.
    pub freq_hz: f64,
    /// Amplitude decay in dB/s (≥ 0).
    pub decay_db_per_s: f64,
    /// Linear input gain (output units per N·s of impulse).
    pub gain: f64,
}

/// A bank of modes with fixed capacity.
#[derive(Debug, Clone)]
pub struct ModalBank {
    sample_rate: f64,
    active: usize,
    pr: Vec<f32>,
    pi: Vec<f32>,
    gain: Vec<f32>,
    zr: Vec<f32>,
    zi: Vec<f32>,
}

impl ModalBank {
    /// Allocates room for `capacity` modes.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            sample_rate: 48_000.0,
            active: 0,
            pr: vec![0.0; capacity],
            pi: vec![0.0; capacity],
            gain: vec![0.0; capacity],
            zr: vec![0.0; capacity],
            zi: vec![0.0; capacity],
        }
    }

    /// Capacity in modes.
    pub fn capacity(&self) -> usize {
        self.pr.len()
    }

    /// Modes currently computed.
    pub fn active(&self) -> usize {
        self.active
    }

    /// Sets the sample rate (coefficients are recomputed by the next `set_modes`).
    pub fn set_sample_rate(&mut self, sample_rate: f64) {
        self.sample_rate = sample_rate;
    }

    /// Sets the modes; keeps the state of modes that stay (glides are phase-continuous).
    /// Modes at or above `MAX_FREQ_FRACTION·fs`, non-finite ones and those beyond capacity are
    /// dropped. Never allocates.
    pub fn set_modes(&mut self, modes: &[ModeParams]) {
        let nyq = MAX_FREQ_FRACTION * self.sample_rate;
        let mut n = 0;
        for m in modes {
            if n == self.capacity() {
                break;
            }
            if !(m.freq_hz > 0.0 && m.freq_hz < nyq) || !m.gain.is_finite() || !m.decay_db_per_s.is_finite() {
                continue;
            }
            let w = std::f64::consts::TAU * m.freq_hz / self.sample_rate;
            let d = m.decay_db_per_s.max(0.0) * std::f64::consts::LN_10 / 20.0 / self.sample_rate;
            let r = (-d).exp();
            self.pr[n] = (r * w.cos()) as f32;
            self.pi[n] = (r * w.sin()) as f32;
            self.gain[n] = m.gain as f32;
            n += 1;
        }
        for i in n..self.active {
            self.zr[i] = 0.0;
            self.zi[i] = 0.0;
        }
        self.active = n;
    }

    /// Clears the state (never allocates).
    pub fn reset(&mut self) {
        self.zr.iter_mut().for_each(|v| *v = 0.0);
        self.zi.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Adds the bank's response to `out`. `input` holds the contact impulse per sample
    /// (force·dt, N·s); `None` means no excitation in this block (free ringing).
    pub fn process(&mut self, input: Option<&[f32]>, out: &mut [f32]) {
        for i in 0..self.active {
            let (pr, pi, g) = (self.pr[i], self.pi[i], self.gain[i]);
            let (mut zr, mut zi) = (self.zr[i], self.zi[i]);
            for (n, o) in out.iter_mut().enumerate() {
                let x = input.map_or(0.0, |x| x[n]) * g;
                let nr = pr * zr - pi * zi + x;
                zi = pr * zi + pi * zr;
                zr = nr;
                *o += zr;
            }
            self.zr[i] = zr;
            self.zi[i] = zi;
        }
    }

    /// Sum of squared mode magnitudes: an upper bound proxy of the output power, for sleeping.
    pub fn energy(&self) -> f32 {
        (0..self.active)
            .map(|i| self.zr[i] * self.zr[i] + self.zi[i] * self.zi[i])
            .sum()
    }
}
