//! Impact contact forces (docs/model.md §5): linear spring half-sine (Traer 2019 eq. 5), raised
//! cosine (Giordano & Avanzini eq. 4.5) and Hunt–Crossley (G&A eq. 4.6) integrated together with
//! the striker's equation of motion `m·ẍ = −f`.
//!
//! Output is the contact impulse per sample, `∫ f dt` over each sample interval in N·s, which is
//! what the modal bank eats. Integrating (rather than point-sampling) the force means a contact
//! shorter than one sample still delivers its exact impulse.
//!
//! * **Spring**: half sine of duration `τ = π·√(m/k)` and peak `v·√(k·m)`; impulse `2·m·v`
//!   (lossless, restitution e = 1). Traer prints the duration as "π·m/k", which is inconsistent
//!   with his own spring model (and dimensionally wrong); we implement `π·√(m/k)`.
//! * **Raised cosine**: same `τ` as the spring and the same impulse `2·m·v` (so both deliver the
//!   same momentum and differ only in pulse shape); since `∫ f = f_max·τ/2`, this gives
//!   `f_max = 4·m·v/τ`, which is `4/π` times the spring's peak.
//! * **Hunt–Crossley**: `f = k_α·x^α·(1 + μ·ẋ)` for compression `x > 0` (i.e. `λ = μ·k_α`, with
//!   μ in s/m as in G&A eq. 4.7), clamped at `f ≥ 0` (a contact cannot pull; the usual fix of the
//!   model's sticky tail). Scaling `x = x₀·X`, `t = (x₀/v)·T` with
//!   `x₀ = ((α+1)·m·v²/(2k_α))^(1/(α+1))` (the lossless maximum compression) turns it into
//!   `X'' = −(α+1)/2 · X^α · max(1 + β·X', 0)`, `X(0) = 0`, `X'(0) = 1`, `β = μ·v`, which is
//!   integrated with RK4 in oversampled sub-steps. Contact time therefore scales as
//!   `x₀/v ∝ (m/k_α)^(1/(α+1))·v^((1−α)/(1+α))`, i.e. `v^(−1/5)` for Hertz (α = 3/2).

/// Nominal RK4 steps per Hunt–Crossley contact. 64 RK4 steps put duration, peak and impulse
/// well inside 0.1 % of a fine f64 solution (tests/integration/impacts.rs).
pub const HC_STEPS_PER_CONTACT: f64 = 64.0;

/// Hard cap on RK4 sub-steps per audio sample. Beyond it (contacts shorter than
/// `64/256 = 1/4` sample) the whole contact is integrated at its start and its impulse delivered
/// in the first sample: the pulse is then so short that its spectrum is flat to within 1 % up to
/// Nyquist, so nothing audible is lost, and per-sample cost stays bounded.
pub const HC_MAX_SUBSTEPS_PER_SAMPLE: u32 = 256;

/// Hard cap on a contact's length in nominal steps (64× the lossless contact time). Heavy
/// damping (large `μ·v`) slows the rebound; past this the contact is declared over so that no
/// input can keep the integrator running forever.
const HC_MAX_CONTACT_STEPS: f64 = 64.0 * HC_STEPS_PER_CONTACT;

/// Dimensionless lossless contact time `T = τ·v/x₀` used only to size the steps: the exact value
/// is 2.943 for α = 3/2 and π for α = 1; 3 is within 5 % over 1 ≤ α ≤ 2.
const HC_NOMINAL_CONTACT_T: f64 = 3.0;

/// Default Hunt–Crossley exponent: Hertz contact of two spheres (G&A §4.3.2).
pub const HC_DEFAULT_EXPONENT: f64 = 1.5;

/// Default Hunt–Crossley damping μ (s/m). Hunt & Crossley relate it to restitution by
/// `μ ≈ 3(1−e)/(2v)`; 0.15 s/m gives e ≈ 0.9 at 1 m/s, typical of hard objects, and restitution
/// that falls with speed as measured for real impacts.
pub const HC_DEFAULT_DAMPING_S_PER_M: f64 = 0.15;

/// Compression (m) at which the Hunt–Crossley spring has the same secant stiffness as the
/// preset's linear `k` (N/m): `k_α = k·x_ref^(1−α)`. 0.1 mm is the spring's maximum compression
/// `v·√(m/k)` for the default 50 g striker at ~0.5 m/s on a 1e6 N/m contact, so both models give
/// similar contact times for typical hits.
pub const HC_REFERENCE_COMPRESSION_M: f64 = 1.0e-4;

/// Speeds below this (m/s) deliver no impact: the impulse would be < 2e-6·m N·s, far below
/// audibility, and the Hunt–Crossley contact time grows without bound as `v → 0`.
pub const MIN_VELOCITY_M_PER_S: f64 = 1.0e-6;

/// Which contact model drives impacts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactModel {
    /// Linear spring: half sine, duration π·√(m/k), peak v·√(k·m).
    Spring,
    /// Raised cosine `f_max/2·(1 − cos(2πt/τ))` with the spring's τ and the same impulse.
    RaisedCosine,
    /// Hunt–Crossley `k·x^α + λ·x^α·ẋ`, integrated with the striker's motion.
    #[default]
    HuntCrossley,
}

/// Physical inputs of one impact. Out-of-range or non-finite values are clamped by
/// [`ImpactForce::start`] (ranges below), so every input gives finite output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImpactParams {
    /// Striker mass in kg, 1e-6 ..= 1e3.
    pub mass_kg: f64,
    /// Impact speed in m/s, 0 ..= 100 (below [`MIN_VELOCITY_M_PER_S`]: no impact).
    pub velocity_m_per_s: f64,
    /// Linear contact stiffness k in N/m, 1 ..= 1e12. Hunt–Crossley uses
    /// [`hunt_crossley_stiffness`] of it.
    pub stiffness_n_per_m: f64,
    /// Contact model.
    pub model: ContactModel,
    /// Hunt–Crossley exponent α, 1 ..= 3 (3/2 = Hertz).
    pub hc_exponent: f64,
    /// Hunt–Crossley damping μ in s/m (λ = μ·k_α), 0 ..= 10.
    pub hc_damping_s_per_m: f64,
}

impl ImpactParams {
    /// Parameters with the default Hunt–Crossley exponent and damping.
    pub fn new(mass_kg: f64, velocity_m_per_s: f64, stiffness_n_per_m: f64, model: ContactModel) -> Self {
        Self {
            mass_kg,
            velocity_m_per_s,
            stiffness_n_per_m,
            model,
            hc_exponent: HC_DEFAULT_EXPONENT,
            hc_damping_s_per_m: HC_DEFAULT_DAMPING_S_PER_M,
        }
    }

    /// Same values clamped to the documented ranges; non-finite values become safe defaults.
    pub fn sanitized(&self) -> Self {
        let c = |v: f64, lo: f64, hi: f64, d: f64| if v.is_finite() { v.clamp(lo, hi) } else { d };
        Self {
            mass_kg: c(self.mass_kg, 1e-6, 1e3, 0.05),
            velocity_m_per_s: c(self.velocity_m_per_s, 0.0, 100.0, 0.0),
            stiffness_n_per_m: c(self.stiffness_n_per_m, 1.0, 1e12, 1e6),
            model: self.model,
            hc_exponent: c(self.hc_exponent, 1.0, 3.0, HC_DEFAULT_EXPONENT),
            hc_damping_s_per_m: c(self.hc_damping_s_per_m, 0.0, 10.0, HC_DEFAULT_DAMPING_S_PER_M),
        }
    }
}

/// Hunt–Crossley stiffness `k_α` (N/m^α) equivalent to a linear `k` (N/m): equal force at
/// [`HC_REFERENCE_COMPRESSION_M`].
pub fn hunt_crossley_stiffness(stiffness_n_per_m: f64, exponent: f64) -> f64 {
    stiffness_n_per_m * HC_REFERENCE_COMPRESSION_M.powf(1.0 - exponent)
}

/// Dimensionless Hunt–Crossley acceleration `X''` (see module docs).
#[inline]
fn hc_accel(x: f64, v: f64, half_a1: f64, alpha: f64, beta: f64) -> f64 {
    if x > 0.0 {
        -half_a1 * x.powf(alpha) * (1.0 + beta * v).max(0.0)
    } else {
        0.0
    }
}

/// One RK4 step of the dimensionless Hunt–Crossley system.
#[inline]
fn hc_rk4(x: f64, v: f64, h: f64, half_a1: f64, alpha: f64, beta: f64) -> (f64, f64) {
    let a = |x, v| hc_accel(x, v, half_a1, alpha, beta);
    let (k1x, k1v) = (v, a(x, v));
    let (k2x, k2v) = (v + 0.5 * h * k1v, a(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
    let (k3x, k3v) = (v + 0.5 * h * k2v, a(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
    let (k4x, k4v) = (v + h * k3v, a(x + h * k3x, v + h * k3v));
    (
        x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
        v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v),
    )
}

/// Dimensionless Hunt–Crossley state and constants of one contact.
#[derive(Debug, Clone, Copy, Default)]
struct HcState {
    /// Compression X = x/x₀.
    x: f64,
    /// Compression velocity X' = ẋ/v.
    v: f64,
    /// Elapsed dimensionless time.
    t: f64,
    /// (α+1)/2.
    half_a1: f64,
    alpha: f64,
    /// μ·v.
    beta: f64,
    /// Sub-step in dimensionless time.
    h: f64,
    /// Sub-steps per audio sample (0: whole contact in the first sample).
    substeps: u32,
    /// Seconds per dimensionless time unit, x₀/v.
    time_scale_s: f64,
    /// Newtons per unit of X'': m·v²/x₀.
    force_scale_n: f64,
}

impl HcState {
    /// Advances one step; returns `false` once the contact has ended (the step that separates
    /// the bodies is truncated at the crossing, found by linear interpolation).
    fn step(&mut self, h: f64) -> bool {
        let (x1, v1) = hc_rk4(self.x, self.v, h, self.half_a1, self.alpha, self.beta);
        if x1 <= 0.0 && v1 < 0.0 {
            let frac = if self.x > x1 { self.x / (self.x - x1) } else { 1.0 };
            self.t += frac * h;
            self.v = v1;
            self.x = 0.0;
            return false;
        }
        self.x = x1;
        self.v = v1;
        self.t += h;
        self.t < HC_MAX_CONTACT_STEPS * HC_NOMINAL_CONTACT_T / HC_STEPS_PER_CONTACT
    }

    /// Dimensionless force of the current state.
    fn force(&self) -> f64 {
        -hc_accel(self.x, self.v, self.half_a1, self.alpha, self.beta)
    }
}

/// Summary of one contact, known when it starts.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContactSummary {
    /// Contact duration in s.
    pub duration_s: f64,
    /// Peak force in N.
    pub peak_force_n: f64,
    /// Total impulse m·v·(1+e) in N·s.
    pub impulse_ns: f64,
    /// Coefficient of restitution e = v_out/v_in.
    pub restitution: f64,
}

/// Generates the force of one impact block by block. Never allocates.
#[derive(Debug, Clone, Default)]
pub struct ImpactForce {
    active: bool,
    model: ContactModel,
    t: f64,
    dt: f64,
    mass_kg: f64,
    velocity_m_per_s: f64,
    summary: ContactSummary,
    hc: HcState,
}

impl ImpactForce {
    /// Starts an impact at `sample_rate` Hz (inputs sanitised, see [`ImpactParams`]).
    pub fn start(&mut self, p: &ImpactParams, sample_rate: f64) {
        let p = p.sanitized();
        let sample_rate = if sample_rate.is_finite() {
            sample_rate.clamp(1.0, 1e9)
        } else {
            48_000.0
        };
        let (m, v, k) = (p.mass_kg, p.velocity_m_per_s, p.stiffness_n_per_m);
        self.model = p.model;
        self.mass_kg = m;
        self.velocity_m_per_s = v;
        self.t = 0.0;
        self.dt = 1.0 / sample_rate;
        self.active = v >= MIN_VELOCITY_M_PER_S;
        if !self.active {
            self.summary = ContactSummary::default();
            return;
        }
        let tau = std::f64::consts::PI * (m / k).sqrt();
        self.summary = match p.model {
            ContactModel::Spring => ContactSummary {
                duration_s: tau,
                peak_force_n: v * (k * m).sqrt(),
                impulse_ns: 2.0 * m * v,
                restitution: 1.0,
            },
            ContactModel::RaisedCosine => ContactSummary {
                duration_s: tau,
                peak_force_n: 4.0 * m * v / tau,
                impulse_ns: 2.0 * m * v,
                restitution: 1.0,
            },
            ContactModel::HuntCrossley => self.start_hc(&p, sample_rate),
        };
    }

    fn start_hc(&mut self, p: &ImpactParams, sample_rate: f64) -> ContactSummary {
        let (m, v, alpha) = (p.mass_kg, p.velocity_m_per_s, p.hc_exponent);
        let k_alpha = hunt_crossley_stiffness(p.stiffness_n_per_m, alpha);
        let x0 = ((alpha + 1.0) * m * v * v / (2.0 * k_alpha)).powf(1.0 / (alpha + 1.0));
        let base = HcState {
            x: 0.0,
            v: 1.0,
            t: 0.0,
            half_a1: 0.5 * (alpha + 1.0),
            alpha,
            beta: p.hc_damping_s_per_m * v,
            h: HC_NOMINAL_CONTACT_T / HC_STEPS_PER_CONTACT,
            substeps: 0,
            time_scale_s: x0 / v,
            force_scale_n: m * v * v / x0,
        };
        // Integrate the whole contact once at the nominal step: gives the summary up front (the
        // transient is scaled by the impulse) and is the delivery path for sub-sample contacts.
        let mut s = base;
        let mut peak: f64 = 0.0;
        while s.step(s.h) {
            peak = peak.max(s.force());
        }
        let e = (-s.v).max(0.0);
        let summary = ContactSummary {
            duration_s: s.t * base.time_scale_s,
            peak_force_n: peak * base.force_scale_n,
            impulse_ns: m * v * (1.0 - s.v),
            restitution: e,
        };
        let dt_t = 1.0 / sample_rate / base.time_scale_s;
        let n = (dt_t / base.h).ceil();
        self.hc = base;
        if n.is_finite() && n <= HC_MAX_SUBSTEPS_PER_SAMPLE as f64 {
            self.hc.substeps = (n as u32).max(1);
            self.hc.h = dt_t / self.hc.substeps as f64;
        } else {
            self.hc.substeps = 0;
        }
        summary
    }

    /// Whether the contact is still on.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// Contact duration in s (analytic for spring and raised cosine, integrated for
    /// Hunt–Crossley).
    pub fn duration_s(&self) -> f64 {
        self.summary.duration_s
    }

    /// Duration, peak force, impulse and restitution of the current contact.
    pub fn summary(&self) -> ContactSummary {
        self.summary
    }

    /// Writes the impulse per sample (N·s) into `out` (overwrites); returns whether any is
    /// non-zero. Never allocates; always finite.
    pub fn fill(&mut self, out: &mut [f32]) -> bool {
        out.iter_mut().for_each(|v| *v = 0.0);
        if !self.active {
            return false;
        }
        match self.model {
            ContactModel::Spring | ContactModel::RaisedCosine => self.fill_analytic(out),
            ContactModel::HuntCrossley => self.fill_hc(out),
        }
        true
    }

    fn fill_analytic(&mut self, out: &mut [f32]) {
        let tau = self.summary.duration_s;
        let peak = self.summary.peak_force_n;
        let spring = self.model == ContactModel::Spring;
        // Primitive of the force: exact impulse over each sample interval.
        let prim = |t: f64| {
            let t = t.clamp(0.0, tau);
            if spring {
                let w = std::f64::consts::PI / tau;
                peak * (1.0 - (w * t).cos()) / w
            } else {
                let w = std::f64::consts::TAU / tau;
                0.5 * peak * (t - (w * t).sin() / w)
            }
        };
        for o in out.iter_mut() {
            let (a, b) = (self.t, self.t + self.dt);
            *o = (prim(b) - prim(a)) as f32;
            self.t = b;
            if self.t >= tau {
                self.active = false;
                break;
            }
        }
    }

    fn fill_hc(&mut self, out: &mut [f32]) {
        let mv = self.mass_kg * self.velocity_m_per_s;
        if self.hc.substeps == 0 {
            // Sub-sample contact: deliver the integrated impulse at once.
            if let Some(o) = out.first_mut() {
                *o = self.summary.impulse_ns as f32;
            }
            self.active = false;
            return;
        }
        for o in out.iter_mut() {
            let v_before = self.hc.v;
            let mut on = true;
            for _ in 0..self.hc.substeps {
                let h = self.hc.h;
                if !self.hc.step(h) {
                    on = false;
                    break;
                }
            }
            // Momentum given to the object this sample = momentum lost by the striker.
            *o = (mv * (v_before - self.hc.v)) as f32;
            if !on {
                self.active = false;
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn render(p: &ImpactParams, sr: f64) -> (ImpactForce, Vec<f64>) {
        let mut f = ImpactForce::default();
        f.start(p, sr);
        let mut all = Vec::new();
        let mut buf = [0f32; 512];
        while f.is_active() && all.len() < 50_000_000 {
            f.fill(&mut buf);
            all.extend(buf.iter().map(|&v| v as f64));
        }
        (f, all)
    }

    #[test]
    fn impulses_are_exact_for_all_models() {
        for model in [
            ContactModel::Spring,
            ContactModel::RaisedCosine,
            ContactModel::HuntCrossley,
        ] {
            for (m, k) in [(0.05, 1e6), (1e-6, 1e11), (2.0, 1e4)] {
                let p = ImpactParams::new(m, 1.3, k, model);
                let (f, out) = render(&p, 48_000.0);
                let j: f64 = out.iter().sum();
                let want = f.summary().impulse_ns;
                assert!((j - want).abs() <= 1e-4 * want, "{model:?} m={m}: {j} vs {want}");
            }
        }
    }

    #[test]
    fn zero_and_nan_velocity_are_silent() {
        for v in [0.0, f64::NAN, -3.0] {
            let mut f = ImpactForce::default();
            f.start(
                &ImpactParams::new(0.05, v, 1e6, ContactModel::HuntCrossley),
                48_000.0,
            );
            assert!(!f.is_active());
        }
    }
}
