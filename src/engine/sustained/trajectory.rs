//! Scraper trajectory S from the surface profile z: the curvature limit of Agarwal et al. 2021
//! eq. 4–5, `S'' = tanh(α(N)·z'') / α(N)`, followed by a Gaussian moving average whose half-width
//! is proportional to α (5 samples at 44.1 kHz for the mean α), and the normal-force law
//! `α(N) = (1 − ν)·α_max + ν·α_min`, `ν = ((N − N_min)/(N_max − N_min))^ζ` (docs/model.md §6).
//!
//! **Normalisation of z'' (what gives α its meaning).** The trajectory is computed along time, on
//! z sampled at audio rate along the path. The curvature fed to the tanh is the vertical
//! acceleration of a point following z, `z̈ ≈ (z[n] − 2z[n−1] + z[n−2])·fs²`, expressed in units of
//! [`A_REF_M_PER_S2`] = 1 µm per (1/44 100 s)², i.e. the second difference in micrometres per
//! sample step at the paper's 44.1 kHz sample rate. For a 1-D path `z̈ = v²·∂²z/∂x² + a·∂z/∂x`, so
//! α applies to the spatial curvature scaled by v²: the clip is a bound on vertical acceleration
//! (|S̈| ≤ A_REF/α, 39 000 m/s² at α_max and 195 000 m/s² at α_min), which is what a bounded
//! force implies (Agarwal §2.2), independent of the sample rate. On a 2-D path the single
//! directional acceleration is clipped instead of x and y separately (rotation invariant; the
//! paper's separate clips differ only on diagonal asperities).
//!
//! S' and S are recovered by leaky integration of the clipped, smoothed S̈ (corner
//! [`LEAK_CORNER_HZ`]), so they track ż and z wherever the clip does not bite and never drift.

/// Exponent ζ of the normal-force law (Agarwal §2.2, "found to yield realistic sounds").
pub const ZETA: f64 = 0.95;
/// α at the smallest normal force (Agarwal §2.2).
pub const ALPHA_MAX: f64 = 0.05;
/// α at the largest normal force (Agarwal §2.2).
pub const ALPHA_MIN: f64 = 0.01;
/// Mean α, the one with the paper's average smoothing half-width.
pub const ALPHA_MEAN: f64 = 0.5 * (ALPHA_MAX + ALPHA_MIN);
/// The paper's sample rate, which fixes the unit of z'' and of the smoothing width.
pub const REF_SAMPLE_RATE_HZ: f64 = 44_100.0;
/// Unit of the vertical acceleration fed to the tanh: 1 µm per reference sample step squared.
pub const A_REF_M_PER_S2: f64 = 1e-6 * REF_SAMPLE_RATE_HZ * REF_SAMPLE_RATE_HZ;
/// Gaussian half-width in samples at 44.1 kHz for α = [`ALPHA_MEAN`] (Agarwal §2.2).
pub const MEAN_HALF_WIDTH_SAMPLES: f64 = 5.0;
/// Normal force at which ν reaches 1 when the force is constant (no motion-given N_min/N_max):
/// 20 N is a firm two-handed press; beyond it the scraper follows z as closely as α_min allows.
pub const FULL_FORCE_N: f64 = 20.0;
/// Precomputed smoothing kernels, linear in half-width from [`MIN_HALF_WIDTH_SAMPLES`] to the
/// widest (α_max at [`MAX_SPEED_WIDENING`]); 128 steps keep the step near 0.3 sample at 48 kHz.
pub const KERNEL_STEPS: usize = 128;
/// Contact speed at which the smoothing has the paper's width (5 samples at 44.1 kHz for the
/// mean α) on the reference contact ([`super::REF_CONTACT_MODULUS_PA`]). The Gaussian models the
/// scraper tip's contact patch, a *spatial* average (a tip cannot follow asperities smaller than
/// itself): its width in time is the patch size over the speed, so it scales as
/// `SMOOTHING_REF_SPEED / v`, and with the patch's width on stiffer surfaces
/// ([`Trajectory::set_patch_scale`]). (Agarwal et al. give the width in samples
/// only; a fixed width in time low-passes the force at a fixed frequency, so loudness stopped
/// rising with speed: the host test's loudness/speed correlation was 0.81.)
pub const SMOOTHING_REF_SPEED_M_PER_S: f64 = 0.5;
/// The widening for slow contacts stops at this factor (v below v_ref/4), bounding the FIR.
pub const MAX_SPEED_WIDENING: f64 = 4.0;
/// Narrowest kernel, samples (σ = a quarter sample: effectively no smoothing).
pub const MIN_HALF_WIDTH_SAMPLES: f64 = 0.5;
/// Corner of the leaky integrators giving S' and S: below the audible band, so S' equals ż there
/// and S cannot drift.
pub const LEAK_CORNER_HZ: f64 = 5.0;

/// α(N) of Agarwal §2.2 for a normal force swinging between `n_min_n` and `n_max_n` (newtons).
/// Larger forces give smaller α, i.e. a higher curvature limit 1/α.
pub fn alpha_for_force(n_n: f64, n_min_n: f64, n_max_n: f64) -> f64 {
    let span = n_max_n - n_min_n;
    let t = if span > 0.0 {
        ((n_n - n_min_n) / span).clamp(0.0, 1.0)
    } else {
        0.5
    };
    let t = if t.is_finite() { t } else { 0.5 };
    let nu = t.powf(ZETA);
    (1.0 - nu) * ALPHA_MAX + nu * ALPHA_MIN
}

/// α for an absolute normal force in newtons, with the range `0..FULL_FORCE_N`.
#[inline]
pub fn alpha_for_pressure(n_n: f64) -> f64 {
    alpha_for_force(n_n, 0.0, FULL_FORCE_N)
}

/// Smoothing half-width in samples for `alpha` at `sample_rate_hz`.
pub fn half_width_samples(alpha: f64, sample_rate_hz: f64) -> f64 {
    MEAN_HALF_WIDTH_SAMPLES * (alpha / ALPHA_MEAN) * (sample_rate_hz / REF_SAMPLE_RATE_HZ)
}

/// tanh to within 1e-4 absolute for all x (Padé 7/6 of the continued fraction, clamped where
/// it reaches 1; the error peaks just below the clamp at ±4.97); the std `tanh` costs more than the whole rest of the per-sample trajectory.
#[inline]
pub fn fast_tanh(x: f32) -> f32 {
    let x = x.clamp(-4.97, 4.97);
    let x2 = x * x;
    let p = x * (135_135.0 + x2 * (17_325.0 + x2 * (378.0 + x2)));
    let q = 135_135.0 + x2 * (62_370.0 + x2 * (3_150.0 + x2 * 28.0));
    (p / q).clamp(-1.0, 1.0)
}

/// One trajectory sample.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TrajectorySample {
    /// S̈, vertical acceleration of the scraper in m/s² (= S_xx·v² on a steady path).
    pub accel_m_per_s2: f64,
    /// Ṡ, vertical velocity in m/s (= v·S').
    pub vel_m_per_s: f64,
    /// S, vertical position in m (zero-mean; sub-audio content removed).
    pub height_m: f64,
}

pub use crate::engine::dsp::trig::fast_sin_cos;

/// Dot product of two equal-length f32 slices in two SSE accumulators (SSE2 is part of the
/// x86-64 baseline, so no runtime detection is needed); LLVM left the portable four-way version
/// scalar. Other targets use four scalar chains.
#[inline]
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        let mut i = 0;
        // SAFETY: SSE2 is always present on x86_64; every load reads 4 f32 at i..i+4 ≤ n.
        unsafe {
            let mut s0 = _mm_setzero_ps();
            let mut s1 = _mm_setzero_ps();
            while i + 8 <= n {
                s0 = _mm_add_ps(
                    s0,
                    _mm_mul_ps(_mm_loadu_ps(a.as_ptr().add(i)), _mm_loadu_ps(b.as_ptr().add(i))),
                );
                s1 = _mm_add_ps(
                    s1,
                    _mm_mul_ps(
                        _mm_loadu_ps(a.as_ptr().add(i + 4)),
                        _mm_loadu_ps(b.as_ptr().add(i + 4)),
                    ),
                );
                i += 8;
            }
            if i + 4 <= n {
                s0 = _mm_add_ps(
                    s0,
                    _mm_mul_ps(_mm_loadu_ps(a.as_ptr().add(i)), _mm_loadu_ps(b.as_ptr().add(i))),
                );
                i += 4;
            }
            let s = _mm_add_ps(s0, s1);
            let s = _mm_add_ps(s, _mm_movehl_ps(s, s));
            let mut total = _mm_cvtss_f32(_mm_add_ss(s, _mm_shuffle_ps::<1>(s, s)));
            while i < n {
                total += a[i] * b[i];
                i += 1;
            }
            total
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut acc = [0.0f32; 4];
        let (ac, ar) = a.as_chunks::<4>();
        let (bc, br) = b.as_chunks::<4>();
        for (x, y) in ac.iter().zip(bc) {
            for l in 0..4 {
                acc[l] += x[l] * y[l];
            }
        }
        let tail: f32 = ar.iter().zip(br).map(|(x, y)| x * y).sum();
        (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
    }
}

/// Entries of the ν = t^ζ table (t = N / [`FULL_FORCE_N`] in 0..1), linearly interpolated.
const NU_TABLE: usize = 256;

/// Streaming curvature limiter + Gaussian smoother + integrators. Allocates in [`Self::prepare`].
#[derive(Debug, Clone)]
pub struct Trajectory {
    fs: f64,
    dt: f64,
    z1: f64,
    z2: f64,
    primed: bool,
    /// Doubled ring of clipped curvatures (units of A_REF) for a contiguous FIR read.
    ring: Vec<f32>,
    pos: usize,
    taps: usize,
    kernels: Vec<f32>,
    /// Per kernel: the tap range within 3σ of the centre.
    ranges: Vec<(usize, usize)>,
    /// Half-widths of the first and last kernel, samples.
    h_lo: f64,
    h_hi: f64,
    /// Per-sample constants folded in `prepare` (no division in `tick` but the speed's):
    /// half-width per unit α in samples, and kernel steps per sample of half-width.
    hw_per_alpha: f64,
    steps_per_sample: f64,
    sdot: f64,
    s: f64,
    leak: f64,
    /// t^ζ at t = i/NU_TABLE (built in `prepare`; empty before it).
    nu_table: Vec<f64>,
    /// Width of the tip's contact patch relative to the reference contact's (1 on wood; a
    /// stiffer surface gives a narrower patch, see [`super::patch_scale`]).
    patch_scale: f64,
    /// Ablation switch: `false` feeds the raw z̈ through (no tanh, no smoothing), as in the
    /// paper's "omitting §2.2" condition.
    pub curvature_limit: bool,
}

impl Default for Trajectory {
    fn default() -> Self {
        let mut t = Self {
            fs: 0.0,
            dt: 0.0,
            z1: 0.0,
            z2: 0.0,
            primed: false,
            ring: Vec::new(),
            pos: 0,
            taps: 1,
            kernels: Vec::new(),
            ranges: Vec::new(),
            h_lo: MIN_HALF_WIDTH_SAMPLES,
            h_hi: MIN_HALF_WIDTH_SAMPLES + 1.0,
            hw_per_alpha: 0.0,
            steps_per_sample: 0.0,
            sdot: 0.0,
            s: 0.0,
            leak: 1.0,
            nu_table: Vec::new(),
            patch_scale: 1.0,
            curvature_limit: true,
        };
        t.prepare(48_000.0);
        t
    }
}

impl Trajectory {
    /// Sets the sample rate and builds the kernels (allocates; not on the audio thread).
    pub fn prepare(&mut self, sample_rate_hz: f64) {
        let fs = if sample_rate_hz.is_finite() {
            sample_rate_hz.clamp(8_000.0, 768_000.0)
        } else {
            48_000.0
        };
        self.fs = fs;
        self.dt = 1.0 / fs;
        self.leak = (-std::f64::consts::TAU * LEAK_CORNER_HZ / fs).exp();
        let h_hi = (half_width_samples(ALPHA_MAX, fs) * MAX_SPEED_WIDENING).max(MIN_HALF_WIDTH_SAMPLES + 1.0);
        let h_max = h_hi.ceil() as usize;
        // The window extends to the largest half-width for every kernel, so the delay (h_max
        // samples) is the same for all and the width can change per sample without a jump in
        // timing; each kernel only sums its taps within 3σ of the centre (`ranges`).
        self.taps = 2 * h_max + 1;
        self.h_lo = MIN_HALF_WIDTH_SAMPLES;
        self.h_hi = h_hi;
        self.hw_per_alpha = half_width_samples(1.0, fs);
        self.steps_per_sample = (KERNEL_STEPS - 1) as f64 / (h_hi - MIN_HALF_WIDTH_SAMPLES);
        self.kernels = vec![0.0; KERNEL_STEPS * self.taps];
        self.ranges = vec![(0, 0); KERNEL_STEPS];
        for j in 0..KERNEL_STEPS {
            let h = self.h_lo + (self.h_hi - self.h_lo) * j as f64 / (KERNEL_STEPS - 1) as f64;
            // Half-width read as 2σ: the kernel has fallen to e^−2 there.
            let sigma = (0.5 * h).max(0.25);
            let reach = ((3.0 * sigma).ceil() as usize).min(h_max);
            let (lo, hi) = (h_max - reach, h_max + reach + 1);
            let k = &mut self.kernels[j * self.taps..(j + 1) * self.taps];
            for (i, w) in k.iter_mut().enumerate() {
                let d = (i as f64 - h_max as f64) / sigma;
                *w = if (lo..hi).contains(&i) {
                    (-0.5 * d * d).exp() as f32
                } else {
                    0.0
                };
            }
            let sum: f32 = k.iter().sum();
            k.iter_mut().for_each(|w| *w /= sum);
            self.ranges[j] = (lo, hi);
        }
        self.ring = vec![0.0; 2 * self.taps];
        self.nu_table = (0..=NU_TABLE)
            .map(|i| (i as f64 / NU_TABLE as f64).powf(ZETA))
            .collect();
        self.reset();
    }

    /// [`alpha_for_pressure`] through a table (no `powf` per sample; error of ν below 2e-4).
    #[inline]
    pub fn alpha_for_pressure(&self, n_n: f64) -> f64 {
        if self.nu_table.len() != NU_TABLE + 1 {
            return alpha_for_pressure(n_n);
        }
        let t = (n_n * (1.0 / FULL_FORCE_N)).clamp(0.0, 1.0);
        let t = if t.is_finite() { t } else { 0.5 };
        let x = t * NU_TABLE as f64;
        let i = (x as usize).min(NU_TABLE - 1);
        let f = x - i as f64;
        let nu = self.nu_table[i] + f * (self.nu_table[i + 1] - self.nu_table[i]);
        (1.0 - nu) * ALPHA_MAX + nu * ALPHA_MIN
    }

    /// Sample rate in Hz.
    pub fn sample_rate(&self) -> f64 {
        self.fs
    }

    /// Sets the tip's contact patch width relative to the reference contact's (the smoothing
    /// width scales with it; see [`super::patch_scale`]). A value that is not finite and
    /// positive keeps the reference width (1). Never allocates.
    pub fn set_patch_scale(&mut self, scale: f64) {
        self.patch_scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
    }

    /// Delay of the smoothed output in samples (centre of the Gaussian window).
    pub fn delay_samples(&self) -> usize {
        self.taps / 2
    }

    /// Clears all state (never allocates).
    pub fn reset(&mut self) {
        self.ring.iter_mut().for_each(|v| *v = 0.0);
        self.pos = 0;
        self.sdot = 0.0;
        self.s = 0.0;
        self.primed = false;
    }

    /// Forgets the height history so the next sample starts with zero curvature (call when the
    /// contact resumes after a pause, so the jump in position does not read as an asperity).
    pub fn reprime(&mut self) {
        self.primed = false;
    }

    /// Advances one sample with surface height `z_m` (metres) at the contact, curvature
    /// parameter `alpha` (clamped to [α_min, α_max]) and contact speed `speed_m_per_s` (sets
    /// the smoothing width, see [`SMOOTHING_REF_SPEED_M_PER_S`]).
    #[inline]
    pub fn tick(&mut self, z_m: f64, alpha: f64, speed_m_per_s: f64) -> TrajectorySample {
        if !self.primed {
            self.z1 = z_m;
            self.z2 = z_m;
            self.primed = true;
        }
        let accel = (z_m - 2.0 * self.z1 + self.z2) * self.fs * self.fs;
        self.z2 = self.z1;
        self.z1 = z_m;
        let accel = if accel.is_finite() { accel } else { 0.0 };
        let s_acc = if self.curvature_limit {
            let alpha = if alpha.is_finite() {
                alpha.clamp(ALPHA_MIN, ALPHA_MAX)
            } else {
                ALPHA_MEAN
            };
            let a = alpha as f32;
            let u = (accel * (1.0 / A_REF_M_PER_S2)) as f32;
            let c = fast_tanh(a * u) / a;
            let taps = self.taps;
            self.ring[self.pos] = c;
            self.ring[self.pos + taps] = c;
            self.pos += 1;
            if self.pos == taps {
                self.pos = 0;
            }
            let v = speed_m_per_s.abs();
            let patch = SMOOTHING_REF_SPEED_M_PER_S * self.patch_scale;
            let widen = if v * MAX_SPEED_WIDENING > patch {
                patch / v
            } else {
                MAX_SPEED_WIDENING
            };
            let h = alpha * self.hw_per_alpha * widen;
            let x = (h - self.h_lo) * self.steps_per_sample + 0.5;
            let j = if x > 0.0 {
                (x as usize).min(KERNEL_STEPS - 1)
            } else {
                0
            };
            let (lo, hi) = self.ranges.get(j).copied().unwrap_or((0, taps));
            let hi = hi.min(taps);
            let lo = lo.min(hi);
            let k = &self.kernels[j * taps..][lo..hi];
            let r = &self.ring[self.pos + lo..self.pos + hi];
            dot(k, r) as f64 * A_REF_M_PER_S2
        } else {
            accel
        };
        self.sdot = self.leak * self.sdot + s_acc * self.dt;
        self.s = self.leak * self.s + self.sdot * self.dt;
        TrajectorySample {
            accel_m_per_s2: s_acc,
            vel_m_per_s: self.sdot,
            height_m: self.s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_tanh_matches_f64() {
        let mut worst = 0.0f64;
        for i in -20_000..=20_000 {
            let x = i as f64 * 1e-3;
            worst = worst.max((fast_tanh(x as f32) as f64 - x.tanh()).abs());
        }
        assert!(worst < 1e-4, "worst {worst}");
    }

    #[test]
    fn alpha_table_matches_law() {
        let mut t = Trajectory::default();
        t.prepare(48_000.0);
        for i in 0..=4000 {
            let n = i as f64 * 0.006;
            let (a, b) = (t.alpha_for_pressure(n), alpha_for_pressure(n));
            assert!(
                (a - b).abs() < 1e-4 * (ALPHA_MAX - ALPHA_MIN) * 10.0,
                "{n}: {a} vs {b}"
            );
        }
    }

    #[test]
    fn alpha_law_endpoints() {
        assert!((alpha_for_force(1.0, 1.0, 3.0) - ALPHA_MAX).abs() < 1e-12);
        assert!((alpha_for_force(3.0, 1.0, 3.0) - ALPHA_MIN).abs() < 1e-12);
        assert!((half_width_samples(ALPHA_MEAN, 44_100.0) - 5.0).abs() < 1e-12);
    }

    #[test]
    fn kernels_sum_to_one_and_small_signals_pass() {
        let mut t = Trajectory::default();
        t.prepare(48_000.0);
        // A slow parabola z = c·n² has z̈ constant, far below the clip: S̈ must equal it.
        let c = 1e-12;
        let mut last = TrajectorySample::default();
        for n in 0..200 {
            last = t.tick(c * (n * n) as f64, ALPHA_MEAN, SMOOTHING_REF_SPEED_M_PER_S);
        }
        let want = 2.0 * c * 48_000.0f64.powi(2);
        assert!(
            (last.accel_m_per_s2 - want).abs() < 1e-3 * want,
            "{} vs {want}",
            last.accel_m_per_s2
        );
    }
}
