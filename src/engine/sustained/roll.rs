//! Rolling contact (MODEL.md §7, Agarwal et al. 2021 §4.1): an eccentric ball of mean radius R
//! with its centre of mass offset by r. Contact point `x = R·θ − r·sin θ`; penetration
//! `ρ = R − r·cos(x/R) + S(x)`, `ρ̇ = ẋ·(r/R)·sin(x/R) + ẋ·S'(x)`; rolling force
//! `f_roll = k·ρ^(3/2) + λ·ρ^(3/2)·ρ̇`, added to the two scraping terms on the contact
//! trajectory. The static part `k·R^(3/2)` is removed (a constant force only makes a click at
//! onset in a modal bank). Normal force `N = pressure·(1 − (r·θ̇²/g)·cos(x/R))`, clamped at 0: the
//! centre of mass circles at rate θ̇, so N swings once per revolution and modulates α(N).

use super::motion::G_M_PER_S2;

/// λ of the rolling term in s/m (Agarwal §4.1, "set by ear to 0.1").
pub const LAMBDA_S_PER_M: f64 = 0.1;
/// Default k in N/m^(3/2): sets the rolling term against the scraping terms (not given by the
/// paper, which mixes by hand); chosen so the once-per-revolution thump is audible but does not
/// dominate the texture at r/R = 0.1.
pub const DEFAULT_K_N_PER_M1_5: f64 = 2.0e3;
/// Smallest ball radius accepted (1 mm).
pub const MIN_RADIUS_M: f64 = 1e-3;
/// Largest ball radius accepted (1 m).
pub const MAX_RADIUS_M: f64 = 1.0;
/// Largest eccentricity r/R accepted (0.5: beyond it the ball is no longer ball-like).
pub const MAX_ECCENTRICITY: f64 = 0.5;

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
        let (s, c) = super::trajectory::fast_sin_cos(th);
        // x/R = θ − (r/R)·sin θ; x/R mod 2π depends only on θ mod 2π.
        let (sx, cx) = super::trajectory::fast_sin_cos(th - ecc * s);
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
