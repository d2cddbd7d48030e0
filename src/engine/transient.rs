//! Impact transient (Traer eq. 3): `h_T(t) = Σ_n 10^((α_n − β_n·t)/20)·ν_n(t)`, with `ν_n` white
//! noise through the n-th ERB-spaced band. One seeded white-noise stream feeds a bank of complex
//! one-pole band filters (bandwidth = 1 ERB, normalised to unit output RMS); each band has its
//! own exponential envelope. Bands that have decayed below the floor stop costing anything.
//!
//! The transient is started by an impact and scaled by the contact impulse (N·s): it is the
//! part of the object's IR that the force excites, approximated as `J·h_T(t)` because contacts
//! (≤ a few ms) are short against the band envelopes.

use super::object::{erb_bandwidth_hz, ObjectBand};

/// Envelope level below which a band stops (linear, relative to a unit impulse): −120 dB.
const BAND_FLOOR: f32 = 1.0e-6;

/// Bank of decaying noise bands. Never allocates after construction.
#[derive(Debug, Clone)]
pub struct TransientBank {
    active: usize,
    pr: Vec<f32>,
    pi: Vec<f32>,
    norm: Vec<f32>,
    env: Vec<f32>,
    env_step: Vec<f32>,
    zr: Vec<f32>,
    zi: Vec<f32>,
    noise_state: u32,
}

impl TransientBank {
    /// Room for `capacity` bands.
    pub fn with_capacity(capacity: usize) -> Self {
        Self {
            active: 0,
            pr: vec![0.0; capacity],
            pi: vec![0.0; capacity],
            norm: vec![0.0; capacity],
            env: vec![0.0; capacity],
            env_step: vec![0.0; capacity],
            zr: vec![0.0; capacity],
            zi: vec![0.0; capacity],
            noise_state: 1,
        }
    }

    /// Bands currently running.
    pub fn active(&self) -> usize {
        self.active
    }

    /// Starts the transient: `impulse_ns` scales all bands; `freq_scale` multiplies centres
    /// (object size); `decay_scale` multiplies decays; `seed` fixes the noise.
    pub fn start(
        &mut self,
        bands: &[ObjectBand],
        impulse_ns: f64,
        freq_scale: f64,
        decay_scale: f64,
        sample_rate: f64,
        seed: u32,
    ) {
        let nyq = 0.49 * sample_rate;
        let mut n = 0;
        for b in bands {
            if n == self.pr.len() {
                break;
            }
            let fc = b.centre_hz * freq_scale;
            if !(fc > 0.0 && fc < nyq) || !b.level_db.is_finite() || !b.decay_db_per_s.is_finite() {
                continue;
            }
            let bw = erb_bandwidth_hz(fc);
            let r = (-std::f64::consts::PI * bw / sample_rate).exp();
            let w = std::f64::consts::TAU * fc / sample_rate;
            self.pr[n] = (r * w.cos()) as f32;
            self.pi[n] = (r * w.sin()) as f32;
            // Re(z) of a complex one-pole fed unit-variance noise has variance 1/(2(1−r²)).
            self.norm[n] = (2.0 * (1.0 - r * r)).sqrt() as f32;
            let amp = impulse_ns.abs() * 10f64.powf(b.level_db / 20.0);
            self.env[n] = amp as f32;
            let d = (b.decay_db_per_s * decay_scale).max(0.0);
            self.env_step[n] = 10f64.powf(-d / 20.0 / sample_rate) as f32;
            self.zr[n] = 0.0;
            self.zi[n] = 0.0;
            if self.env[n] > BAND_FLOOR * 1e-3 {
                n += 1;
            }
        }
        self.active = n;
        self.noise_state = seed | 1;
    }

    /// Stops everything.
    pub fn reset(&mut self) {
        self.active = 0;
    }

    /// Adds the transient to `out`; drops bands whose envelope fell below the floor.
    pub fn process(&mut self, out: &mut [f32]) {
        if self.active == 0 {
            return;
        }
        for o in out.iter_mut() {
            // xorshift32 → uniform in [−1, 1) scaled to unit variance (√3).
            let mut s = self.noise_state;
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            self.noise_state = s;
            let x = ((s as i32) as f32 * (1.0 / 2_147_483_648.0)) * 1.732_050_8;
            let mut acc = 0.0;
            for i in 0..self.active {
                let xi = x * self.norm[i];
                let nr = self.pr[i] * self.zr[i] - self.pi[i] * self.zi[i] + xi;
                self.zi[i] = self.pr[i] * self.zi[i] + self.pi[i] * self.zr[i];
                self.zr[i] = nr;
                acc += self.env[i] * nr;
                self.env[i] *= self.env_step[i];
            }
            *o += acc;
        }
        let mut i = 0;
        while i < self.active {
            if self.env[i] < BAND_FLOOR * 1e-3 {
                let last = self.active - 1;
                self.pr.swap(i, last);
                self.pi.swap(i, last);
                self.norm.swap(i, last);
                self.env.swap(i, last);
                self.env_step.swap(i, last);
                self.zr.swap(i, last);
                self.zi.swap(i, last);
                self.active -= 1;
            } else {
                i += 1;
            }
        }
    }
}
