//! Seeded fractal surface height profile z(x) and a cheap z(x, y) (docs/model.md §6; Agarwal 2021
//! §2.2 uses measured depth maps, Tactus synthesises them as the paper proposes for future work).
//!
//! The profile is a periodic table of [`TABLE_LEN`] points of unit-RMS 1/f^β noise built once by
//! spectral synthesis (random phases, power spectrum `P(k) ∝ (k² + k_w²)^−β/2`, flat below the
//! waviness corner `k_w` and 1/f^β up to the grain size, Gaussian roll-off below the grain size). Lookups interpolate with a cubic
//! Hermite (Catmull–Rom) spline, so a scrape of any length reads the same table: no long buffers.
//! Units: x, y and the grain size in metres; [`Surface::height`] is dimensionless (unit RMS) and
//! the caller scales it by the RMS roughness height in metres.
//!
//! z(x, y) sums the 1-D profile along three directions 60° apart, each with its own offset into
//! the table, divided by √3 (still unit RMS): cheap, no 2-D table, and a 2-D path does not retrace
//! a 1-D loop. It is not isotropic fractal noise, which a listener cannot hear through a scrape.

use super::super::object::EngineRng;
use rand::{RngExt, SeedableRng};
use realfft::RealFftPlanner;

/// Table points per period (2^16): 256 KiB of f32, built once at construction.
pub const TABLE_LEN: usize = 1 << 16;
/// Table points per grain size. Four points resolve the grain's roll-off corner with the cubic
/// interpolation; more would only shorten the period.
pub const POINTS_PER_GRAIN: f64 = 4.0;
/// The 1/f^β slope flattens at wavelengths above this many grains. Longer waviness is not
/// roughness: at scraping speeds it is sub-audio, and without the corner it would hold nearly all
/// of the RMS height (for β = 2), leaving the audible texture tiny for a given roughness.
pub const WAVINESS_GRAINS: f64 = 64.0;
pub use crate::engine::limits::{MAX_GRAIN_M, MIN_GRAIN_M};

/// A periodic unit-RMS fractal height profile.
#[derive(Debug, Clone)]
pub struct Surface {
    table: Vec<f32>,
    spacing_m: f64,
    inv_spacing: f64,
    grain_m: f64,
    beta: f64,
}

impl Surface {
    /// Builds a surface (allocates and runs one inverse FFT: not for the audio thread).
    /// `grain_m` is the grain size in metres (clamped to [`MIN_GRAIN_M`, `MAX_GRAIN_M`]): below it
    /// the profile is smooth. `beta` is the spectral exponent of the height power spectrum
    /// (clamped to 0..4; 2 = Brownian profile, typical of machined and worn surfaces).
    pub fn new(seed: u64, grain_m: f64, beta: f64) -> Self {
        let grain_m = if grain_m.is_finite() {
            grain_m.clamp(MIN_GRAIN_M, MAX_GRAIN_M)
        } else {
            50e-6
        };
        let beta = if beta.is_finite() {
            beta.clamp(0.0, 4.0)
        } else {
            2.0
        };
        let n = TABLE_LEN;
        let spacing_m = grain_m / POINTS_PER_GRAIN;
        let mut rng = EngineRng::seed_from_u64(seed ^ 0x5eed_5c7a_9e00_0001);
        let mut planner = RealFftPlanner::<f64>::new();
        let c2r = planner.plan_fft_inverse(n);
        let mut spec = c2r.make_input_vec();
        let mut out = c2r.make_output_vec();
        // Bin k has spatial frequency k / period = k / (n · spacing); the grain corner is at
        // 1/grain, i.e. bin n / POINTS_PER_GRAIN.
        let k_grain = n as f64 / POINTS_PER_GRAIN;
        let k_low = k_grain / WAVINESS_GRAINS;
        for (k, c) in spec.iter_mut().enumerate() {
            if k == 0 || k == n / 2 {
                *c = realfft::num_complex::Complex::new(0.0, 0.0);
                continue;
            }
            let kf = k as f64;
            let amp = (kf * kf + k_low * k_low).powf(-beta / 4.0) * (-0.5 * (kf / k_grain).powi(2)).exp();
            let phase = std::f64::consts::TAU * rng.random::<f64>();
            *c = realfft::num_complex::Complex::from_polar(amp, phase);
        }
        c2r.process(&mut spec, &mut out)
            .expect("spectrum sized by the plan");
        let rms = (out.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
        let scale = if rms > 0.0 { 1.0 / rms } else { 0.0 };
        let table = out.iter().map(|v| (v * scale) as f32).collect();
        Self {
            table,
            spacing_m,
            inv_spacing: 1.0 / spacing_m,
            grain_m,
            beta,
        }
    }

    /// Grain size in metres.
    pub fn grain_m(&self) -> f64 {
        self.grain_m
    }

    /// Spectral exponent β.
    pub fn beta(&self) -> f64 {
        self.beta
    }

    /// Period of the profile in metres (`TABLE_LEN · grain / POINTS_PER_GRAIN`).
    pub fn period_m(&self) -> f64 {
        self.spacing_m * TABLE_LEN as f64
    }

    /// Unit-RMS height at position `x_m` (metres, any real value; the profile is periodic).
    #[inline]
    pub fn height(&self, x_m: f64) -> f64 {
        let u = x_m * self.inv_spacing;
        // floor(u) by truncation (no libm call on the baseline target): one less below zero.
        let tr = u as i64;
        let fi = tr - i64::from(u < tr as f64);
        let t = (u - fi as f64) as f32;
        // Wrapping through i64 then masking keeps negative positions valid.
        let i = fi as usize;
        let m = TABLE_LEN - 1;
        let p0 = self.table[i.wrapping_sub(1) & m];
        let p1 = self.table[i & m];
        let p2 = self.table[i.wrapping_add(1) & m];
        let p3 = self.table[i.wrapping_add(2) & m];
        // Catmull–Rom: C1-continuous, so the slope seen by the trajectory has no steps.
        let a = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3;
        let b = p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3;
        let c = 0.5 * (p2 - p0);
        (((a * t + b) * t + c) * t + p1) as f64
    }

    /// Unit-RMS height at (x, y) in metres: three 1-D profiles 60° apart, offset in the table.
    #[inline]
    pub fn height_2d(&self, x_m: f64, y_m: f64) -> f64 {
        // cos/sin of 0°, 60°, 120°; offsets of a third of the period decorrelate the three.
        const C60: f64 = 0.5;
        const S60: f64 = 0.866_025_403_784_438_6;
        let third = self.period_m() / 3.0;
        let h = self.height(x_m)
            + self.height(C60 * x_m + S60 * y_m + third)
            + self.height(-C60 * x_m + S60 * y_m + 2.0 * third);
        h * (1.0 / 3.0f64.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_rms_periodic_and_seeded() {
        let s = Surface::new(7, 50e-6, 2.0);
        let n = 20_000;
        let p = s.period_m();
        let rms = ((0..n)
            .map(|i| s.height(i as f64 * p / n as f64).powi(2))
            .sum::<f64>()
            / n as f64)
            .sqrt();
        assert!((rms - 1.0).abs() < 0.1, "rms {rms}");
        assert!((s.height(0.123) - s.height(0.123 + p)).abs() < 1e-4);
        assert!((s.height(-0.01) - s.height(-0.01 + p)).abs() < 1e-4);
        let t = Surface::new(7, 50e-6, 2.0);
        assert_eq!(s.height(0.3), t.height(0.3));
        let u = Surface::new(8, 50e-6, 2.0);
        assert_ne!(s.height(0.3), u.height(0.3));
    }
}
