//! Impact contact forces (MODEL.md §5): linear spring half-sine (Traer eq. 5), raised cosine
//! (Giordano & Avanzini eq. 4.5) and Hunt–Crossley (eq. 4.6).
//!
//! PROVISIONAL: only the spring model is implemented so far; the others fall back to it.
//! Output is the contact impulse per sample, `f(t)·dt` in N·s, which is what the modal bank eats.

/// Which contact model drives impacts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactModel {
    /// Linear spring: half sine, duration π·√(m/k), peak v·√(k·m).
    #[default]
    Spring,
    /// Raised cosine `f_max/2·(1 − cos(2πt/τ))` with the spring's τ and the same impulse.
    RaisedCosine,
    /// Hunt–Crossley `k·x^α + λ·x^α·ẋ`, integrated with the striker's motion.
    HuntCrossley,
}

/// Physical inputs of one impact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactParams {
    /// Striker mass in kg.
    pub mass_kg: f64,
    /// Impact speed in m/s.
    pub velocity_m_per_s: f64,
    /// Contact stiffness k in N/m (N/m^α for Hunt–Crossley).
    pub stiffness: f64,
    /// Contact model.
    pub model: ContactModel,
}

/// Generates the force of one impact block by block. Never allocates.
#[derive(Debug, Clone, Default)]
pub struct ImpactForce {
    active: bool,
    t: f64,
    dt: f64,
    duration_s: f64,
    peak_n: f64,
}

impl ImpactForce {
    /// Starts an impact.
    pub fn start(&mut self, p: &ImpactParams, sample_rate: f64) {
        let m = p.mass_kg.max(1e-9);
        let k = p.stiffness.max(1.0);
        let v = p.velocity_m_per_s.max(0.0);
        self.duration_s = std::f64::consts::PI * (m / k).sqrt();
        self.peak_n = v * (k * m).sqrt();
        self.t = 0.0;
        self.dt = 1.0 / sample_rate;
        self.active = v > 0.0;
    }

    /// Whether the contact is still on.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// Contact duration in s.
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Writes the impulse per sample (N·s) into `out` (overwrites); returns whether any is non-zero.
    pub fn fill(&mut self, out: &mut [f32]) -> bool {
        out.iter_mut().for_each(|v| *v = 0.0);
        if !self.active {
            return false;
        }
        // Sample the half sine's integral over each sample interval, so contacts shorter than a
        // sample still deliver their exact impulse.
        let w = std::f64::consts::PI / self.duration_s;
        let prim = |t: f64| {
            let t = t.clamp(0.0, self.duration_s);
            self.peak_n * (1.0 - (w * t).cos()) / w
        };
        for o in out.iter_mut() {
            let (a, b) = (self.t, self.t + self.dt);
            *o = (prim(b) - prim(a)) as f32;
            self.t = b;
            if self.t >= self.duration_s {
                self.active = false;
                break;
            }
        }
        true
    }
}
