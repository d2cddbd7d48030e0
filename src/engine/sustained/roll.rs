//! Rolling contact (docs/model.md §7, Agarwal et al. 2021 §4.1): an eccentric ball of mean radius R
//! with its centre of mass offset by r. Contact point `x = R·θ − r·sin θ`; penetration
//! `ρ = R − r·cos(x/R) + S(x)`, `ρ̇ = ẋ·(r/R)·sin(x/R) + ẋ·S'(x)`; rolling force
//! `f_roll = k·ρ^(3/2) + λ·ρ^(3/2)·ρ̇`, added to the two scraping terms on the contact
//! trajectory. The static part `k·R^(3/2)` is removed (a constant force only makes a click at
//! onset in a modal bank). Normal force `N = pressure·(1 − (r·θ̇²/g)·cos(x/R))`, clamped at 0: the
//! centre of mass circles at rate θ̇, so N swings once per revolution and modulates α(N).

use super::motion::G_M_PER_S2;
use crate::engine::dsp::simd::Kernel;
use crate::engine::dsp::trig::fast_sin_cos;

/// The patch filter's coefficient is refreshed every this many samples of the voice's own
/// clock (a fixed grid, so renders do not depend on the host's block size). Why 32: the load
/// and speed change at the rotation rate (tens of Hz), far slower than 0.7 ms.
pub const PATCH_UPDATE_SAMPLES: u64 = 32;

/// Hertzian contact half-width `a = (3·N·R / (4·E*))^(1/3)` in m for load `normal_n` (N), ball
/// radius `radius_m` and effective modulus `modulus_pa` (E*, [`super::contact_modulus_pa`])
/// (Hertz 1882; Johnson, *Contact Mechanics*, §4.2).
#[inline]
pub fn hertz_half_width_m(normal_n: f64, radius_m: f64, modulus_pa: f64) -> f64 {
    (3.0 * normal_n.max(0.0) * radius_m / (4.0 * modulus_pa)).cbrt()
}

/// The ball's contact patch as a low-pass of the surface profile: the ball rests on the
/// pressure-weighted mean height across its patch (width 2a), not on a single point, so
/// asperities shorter than the patch are bridged. Hertz's pressure `p ∝ √(1 − x²/a²)` has a
/// spatial SD of a/2; at contact speed v that is `σ_t = a/(2v)` in time, realised as four
/// cascaded one-poles of time constant `σ_t/2` (a gamma kernel with the same variance: −24 dB per
/// octave, no ringing). Bigger balls and heavier loads widen the patch and darken the sound;
/// the eccentric load swing of each revolution widens and narrows it once per turn.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HertzPatch {
    y: [f64; 4],
    c: f64,
    clock: u64,
    primed: bool,
}

impl HertzPatch {
    /// Forgets the state (the next contact starts from its first height). Never allocates.
    pub fn reset(&mut self) {
        *self = Self::default();
    }

    /// Filters one height sample `z_m` (m) under load `normal_n` (N) at contact speed
    /// `speed_m_per_s`, for a ball of radius `radius_m` on a surface of effective modulus
    /// `modulus_pa` (positive), at sample period `dt_s`.
    #[inline]
    pub fn tick(
        &mut self,
        z_m: f64,
        normal_n: f64,
        speed_m_per_s: f64,
        radius_m: f64,
        modulus_pa: f64,
        dt_s: f64,
    ) -> f64 {
        if self.clock.is_multiple_of(PATCH_UPDATE_SAMPLES) || !self.primed {
            let a = hertz_half_width_m(normal_n, radius_m, modulus_pa);
            let v = speed_m_per_s.abs();
            // τ = σ_t/2 = a/(4v); the coefficient is exp(−dt/τ) (0 = no filtering).
            self.c = if a > 0.0 { (-dt_s * 4.0 * v / a).exp() } else { 0.0 };
        }
        self.clock = self.clock.wrapping_add(1);
        if !self.primed {
            self.y = [z_m; 4];
            self.primed = true;
        }
        let g = 1.0 - self.c;
        let mut x = z_m;
        for y in self.y.iter_mut() {
            *y += g * (x - *y);
            x = *y;
        }
        x
    }
}

/// λ of the rolling term in s/m (Agarwal §4.1, "set by ear to 0.1").
pub const LAMBDA_S_PER_M: f64 = 0.1;
/// Default k in N/m^(3/2): sets the rolling term against the scraping terms (not given by the
/// paper, which mixes by hand); chosen so the once-per-revolution thump is audible but does not
/// dominate the texture at r/R = 0.1.
pub const DEFAULT_K_N_PER_M1_5: f64 = 2.0e3;
pub use crate::engine::limits::{MAX_ECCENTRICITY, MAX_RADIUS_M, MIN_RADIUS_M};

/// Kinematic state of the rolling ball. Never allocates.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RollState {
    /// Rotation angle θ in rad, wrapped to [0, 2π).
    pub theta_rad: f64,
}

/// Per-sample rolling kinematics.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RollKinematics {
    /// ẋ, speed of the contact point along the surface in m/s.
    pub contact_speed_m_per_s: f64,
    /// cos(x/R).
    pub cos_xr: f64,
    /// sin(x/R).
    pub sin_xr: f64,
    /// θ̇ in rad/s.
    pub theta_rate_rad_per_s: f64,
}

impl RollState {
    /// Advances θ by one sample for centre speed `speed_m_per_s`, radius `radius_m`, eccentricity
    /// `ecc` (r/R), and returns the kinematics at the new angle.
    #[inline]
    pub fn advance(&mut self, speed_m_per_s: f64, radius_m: f64, ecc: f64, dt_s: f64) -> RollKinematics {
        let w = speed_m_per_s / radius_m;
        self.theta_rad += w * dt_s;
        if self.theta_rad >= std::f64::consts::TAU || self.theta_rad < 0.0 {
            self.theta_rad = self.theta_rad.rem_euclid(std::f64::consts::TAU);
        }
        let th = self.theta_rad;
        let (s, c) = fast_sin_cos(th);
        // x/R = θ − (r/R)·sin θ; x/R mod 2π depends only on θ mod 2π.
        let (sx, cx) = fast_sin_cos(th - ecc * s);
        RollKinematics {
            contact_speed_m_per_s: w * radius_m * (1.0 - ecc * c),
            cos_xr: cx,
            sin_xr: sx,
            theta_rate_rad_per_s: w,
        }
    }
}

/// Normal force in N of the eccentric ball with mean force `pressure_n`.
#[inline]
pub fn roll_normal_n(pressure_n: f64, radius_m: f64, ecc: f64, k: &RollKinematics) -> f64 {
    let r = ecc * radius_m;
    (pressure_n * (1.0 - r * k.theta_rate_rad_per_s * k.theta_rate_rad_per_s / G_M_PER_S2 * k.cos_xr))
        .max(0.0)
}

/// The rolling term in N, static part removed. `s_m`/`sdot_m_per_s` are the contact trajectory's
/// S and Ṡ = ẋ·S'.
#[inline]
pub fn roll_force_n(
    k_n_per_m1_5: f64,
    lambda: f64,
    radius_m: f64,
    ecc: f64,
    kin: &RollKinematics,
    s_m: f64,
    sdot_m_per_s: f64,
) -> f64 {
    let r = ecc * radius_m;
    let rho = (radius_m - r * kin.cos_xr + s_m).max(0.0);
    let rho_dot = kin.contact_speed_m_per_s * ecc * kin.sin_xr + sdot_m_per_s;
    let r15 = rho * rho.sqrt();
    k_n_per_m1_5 * (r15 * (1.0 + lambda * rho_dot) - radius_m * radius_m.sqrt())
}

/// Samples per kinematics chunk of [`super::SustainedVoice`]'s rolling loop (stack arrays).
pub const BLOCK: usize = 64;

/// Per-chunk rolling kinematics in structure-of-arrays form (stack scratch, never allocates).
/// The rolling loop fills it in passes: rates and angles (serial running sum), then the
/// trigonometry and normal force of every sample at once ([`kinematics`], vectorised: two
/// [`fast_sin_cos`] per sample were most of a rolling voice's own cost).
/// Exactly the per-sample [`RollState::advance`] and [`roll_normal_n`], reordered.
#[derive(Debug, Clone, Copy)]
pub struct RollBlock {
    /// θ̇ in rad/s (input of the passes).
    pub theta_rate: [f64; BLOCK],
    /// θ after each sample's advance, rad.
    pub theta: [f64; BLOCK],
    /// ẋ in m/s.
    pub contact_speed: [f64; BLOCK],
    /// cos(x/R).
    pub cos_xr: [f64; BLOCK],
    /// sin(x/R).
    pub sin_xr: [f64; BLOCK],
    /// Normal force N in newtons.
    pub normal: [f64; BLOCK],
    /// Surface height under the contact (scaled by the roughness), m.
    pub height: [f64; BLOCK],
    /// Trajectory S̈ (m/s²), Ṡ (m/s) and S (m).
    pub traj_accel: [f64; BLOCK],
    /// Trajectory Ṡ, m/s.
    pub traj_vel: [f64; BLOCK],
    /// Trajectory S, m.
    pub traj_height: [f64; BLOCK],
    /// Rolling term plus the ball's inertial term `m·S̈`, N.
    pub force: [f64; BLOCK],
}

impl Default for RollBlock {
    fn default() -> Self {
        Self {
            theta_rate: [0.0; BLOCK],
            theta: [0.0; BLOCK],
            contact_speed: [0.0; BLOCK],
            cos_xr: [0.0; BLOCK],
            sin_xr: [0.0; BLOCK],
            normal: [0.0; BLOCK],
            height: [0.0; BLOCK],
            traj_accel: [0.0; BLOCK],
            traj_vel: [0.0; BLOCK],
            traj_height: [0.0; BLOCK],
            force: [0.0; BLOCK],
        }
    }
}

/// Per-block constants of [`kinematics`].
#[derive(Debug, Clone, Copy)]
pub struct RollConsts {
    /// Mean normal force, N.
    pub pressure_n: f64,
    /// Ball radius R, m.
    pub radius_m: f64,
    /// r/R.
    pub ecc: f64,
    /// `false` holds N at the pressure (ablation).
    pub varying_normal_force: bool,
}

impl RollConsts {
    /// Bundles the constants.
    pub fn new(pressure_n: f64, radius_m: f64, ecc: f64, varying_normal_force: bool) -> Self {
        Self {
            pressure_n,
            radius_m,
            ecc,
            varying_normal_force,
        }
    }
}

impl RollState {
    /// Pass 1 of the chunked loop: advances θ through the first `n` rates of `b.theta_rate`
    /// (θ̇ = v/R per sample) and stores each new angle in `b.theta` (as [`Self::advance`]).
    #[inline]
    pub fn advance_block(&mut self, b: &mut RollBlock, n: usize, dt_s: f64) {
        let n = n.min(BLOCK);
        for (th, &w) in b.theta[..n].iter_mut().zip(&b.theta_rate[..n]) {
            self.theta_rad += w * dt_s;
            if self.theta_rad >= std::f64::consts::TAU || self.theta_rad < 0.0 {
                self.theta_rad = self.theta_rad.rem_euclid(std::f64::consts::TAU);
            }
            *th = self.theta_rad;
        }
    }
}

#[inline(always)]
fn kinematics_generic(c: &RollConsts, b: &mut RollBlock, n: usize) {
    let n = n.min(BLOCK);
    let r = c.ecc * c.radius_m;
    for i in 0..n {
        let th = b.theta[i];
        let w = b.theta_rate[i];
        let (s, co) = fast_sin_cos(th);
        // x/R = θ − (r/R)·sin θ; x/R mod 2π depends only on θ mod 2π.
        let (sx, cx) = fast_sin_cos(th - c.ecc * s);
        b.contact_speed[i] = w * c.radius_m * (1.0 - c.ecc * co);
        b.cos_xr[i] = cx;
        b.sin_xr[i] = sx;
        // As `roll_normal_n`.
        b.normal[i] = if c.varying_normal_force {
            (c.pressure_n * (1.0 - r * w * w / G_M_PER_S2 * cx)).max(0.0)
        } else {
            c.pressure_n
        };
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn kinematics_avx2(c: &RollConsts, b: &mut RollBlock, n: usize) {
    kinematics_generic(c, b, n)
}

/// Pass 2 of the chunked loop: contact speed, cos/sin(x/R) and N of the first `n` samples from
/// `b.theta` and `b.theta_rate`, in the AVX2 variant when `kernel` allows it. No dependency
/// between samples, so it runs 4 samples per AVX2 instruction (2 on the SSE2 baseline).
#[inline]
pub fn kinematics(kernel: Kernel, c: &RollConsts, b: &mut RollBlock, n: usize) {
    match kernel {
        // SAFETY: `kernel`'s features (AVX-512 implies AVX2 + FMA here) were detected at runtime
        // (`dsp::simd` invariant).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 | Kernel::Avx2 => unsafe { kinematics_avx2(c, b, n) },
        _ => kinematics_generic(c, b, n),
    }
}

#[inline(always)]
fn forces_generic(c: &RollConsts, k: f64, probe_mass_kg: f64, b: &mut RollBlock, n: usize) {
    let n = n.min(BLOCK);
    for i in 0..n {
        let kin = RollKinematics {
            contact_speed_m_per_s: b.contact_speed[i],
            cos_xr: b.cos_xr[i],
            sin_xr: b.sin_xr[i],
            theta_rate_rad_per_s: b.theta_rate[i],
        };
        let roll = roll_force_n(
            k,
            LAMBDA_S_PER_M,
            c.radius_m,
            c.ecc,
            &kin,
            b.traj_height[i],
            b.traj_vel[i],
        );
        b.force[i] = probe_mass_kg * b.traj_accel[i] + roll;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn forces_avx2(c: &RollConsts, k: f64, probe_mass_kg: f64, b: &mut RollBlock, n: usize) {
    forces_generic(c, k, probe_mass_kg, b, n)
}

/// Pass 5 of the chunked loop: `b.force` = [`roll_force_n`] + `m·S̈` (m = the ball's mass) for the first `n`
/// samples (no dependency between samples; one square root each, vectorised).
#[inline]
pub fn forces(kernel: Kernel, c: &RollConsts, k: f64, probe_mass_kg: f64, b: &mut RollBlock, n: usize) {
    match kernel {
        // SAFETY: as in `kinematics`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 | Kernel::Avx2 => unsafe { forces_avx2(c, k, probe_mass_kg, b, n) },
        _ => forces_generic(c, k, probe_mass_kg, b, n),
    }
}
