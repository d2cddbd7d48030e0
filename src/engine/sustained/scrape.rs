//! Scraping contact force (docs/model.md §6, Agarwal et al. 2021 eq. 1–3, after Traer 2019 §4):
//! vertical `f_v = m_p·(S_xx·v_x² + S_yy·v_y²)` and horizontal `f_h = β1·(v_x·S_x + v_y·S_y)^β2`,
//! total `f = f_v + f_h`. On the time-domain trajectory of [`super::trajectory`] these are
//! `f_v = m_p·S̈` and `f_h = β1·Ṡ^β2` (signed power), with S̈ and Ṡ along the actual path.

use super::trajectory::TrajectorySample;

/// β1 of the horizontal term in N·s/m (Agarwal §2.1).
pub const BETA1_N_S_PER_M: f64 = 0.05;
/// β2 of the horizontal term (Agarwal §2.1: linear).
pub const BETA2: f64 = 1.0;
/// Default probe (scraper tip) mass: 10 g, the effective mass of a hand-held tool's tip.
pub const DEFAULT_PROBE_MASS_KG: f64 = 0.01;

/// Coefficients of the scraping force law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScrapeLaw {
    /// m_p, probe mass in kg.
    pub probe_mass_kg: f64,
    /// β1 in N·s/m (for β2 = 1).
    pub beta1: f64,
    /// β2, exponent of the horizontal term.
    pub beta2: f64,
}

impl Default for ScrapeLaw {
    fn default() -> Self {
        Self {
            probe_mass_kg: DEFAULT_PROBE_MASS_KG,
            beta1: BETA1_N_S_PER_M,
            beta2: BETA2,
        }
    }
}

impl ScrapeLaw {
    /// Vertical force in N.
    #[inline]
    pub fn vertical_n(&self, s: &TrajectorySample) -> f64 {
        self.probe_mass_kg * s.accel_m_per_s2
    }

    /// Horizontal force in N (signed power keeps the sign of v·S').
    #[inline]
    pub fn horizontal_n(&self, s: &TrajectorySample) -> f64 {
        let x = s.vel_m_per_s;
        if self.beta2 == 1.0 {
            self.beta1 * x
        } else {
            self.beta1 * x.signum() * x.abs().powf(self.beta2)
        }
    }

    /// Total scraping force in N.
    #[inline]
    pub fn total_n(&self, s: &TrajectorySample) -> f64 {
        self.vertical_n(s) + self.horizontal_n(s)
    }
}
