//! Sustained contact: scraping and rolling force generators (docs/model.md §6–7, Agarwal et al. 2021
//! "Object-based synthesis of scraping and rolling sounds", building on Traer et al. 2019 §4).
//!
//! Pipeline per sample: motion (velocity, normal force N) → position → surface height z
//! ([`surface`]) → curvature-limited, smoothed trajectory S with α(N) ([`trajectory`], eq. 4–5) →
//! scraping force `m_p·S̈ + β1·Ṡ` ([`scrape`]) (+ rolling term, [`roll`]) → impulse per sample
//! `f/fs` in N·s, the input [`crate::engine::modal::ModalBank::process`] expects.
//!
//! ## Public API (for the engine / plugin / scene integration)
//! - [`SustainedVoice::new(sample_rate_hz, seed)`](SustainedVoice::new) allocates (surface table
//!   256 KiB, smoothing kernels); [`SustainedVoice::prepare`] on sample-rate change (allocates);
//!   [`SustainedVoice::set_surface`] rebuilds the surface (allocates, not on the audio thread);
//!   [`SustainedVoice::restart`] / [`SustainedVoice::reset`] never allocate.
//! - Per block: fill a [`SustainedParams`] (plain values in physical units, from the plugin's
//!   `scrape_*`/`roll_*` parameters or a scene) and call
//!   [`SustainedVoice::process(&params, speed_input, impulse_out)`](SustainedVoice::process).
//!   It returns `false` when there is nothing to compute (speed 0, pressure 0, or a finished long
//!   stroke): then `impulse_out` is left untouched, no sample was computed, and the caller should
//!   run the bank with `input = None` so it free-rings and can sleep. On `true` every sample of
//!   `impulse_out` is overwritten with a finite impulse (N·s). `speed_input` (signed m/s per
//!   sample, automation) is read in [`MotionKind::Manual`] scraping and in rolling (ball
//!   speed); otherwise `params.scrape_speed_m_per_s` / `params.roll_speed_m_per_s` is used.
//!   Preset motions always take the constant peak speed (their phase is `ω·t`). Never allocates, locks or panics.
//! - Ablation switches are plain `pub bool` fields of the voice: `curvature_limit`,
//!   `varying_normal_force`.
//! - [`SustainedVoice::last_normal_n`] / [`SustainedVoice::position_m`] expose the contact state
//!   (e.g. for the lead's position-dependent mode morphing); [`SustainedVoice::samples_computed`]
//!   counts computed samples (tests and stats).
//!
//! The force is independent of the mode count: one voice per contact feeds any bank.
//!
//! Rolling is computed in chunks of [`roll::BLOCK`] samples, pass by pass (angle running sum,
//! vectorised trigonometry and N, positions and heights, trajectory, vectorised rolling term):
//! the same arithmetic as the per-sample loop in the same order per sample, so the output is
//! identical (unit test against the per-sample reference); only the trajectory keeps a
//! per-sample dependency chain.

pub mod channel;
pub mod measured;
pub mod measured_data;
pub mod motion;
pub mod roll;
pub mod scrape;
pub mod surface;
pub mod trajectory;

pub use measured::{MeasuredSurface, SurfaceKind};
pub use motion::{Motion, MotionKind, MotionSample};
pub use scrape::ScrapeLaw;
pub use surface::Surface;
pub use trajectory::{Trajectory, TrajectorySample};

use crate::engine::settings::{RollParams, ScrapeParams};
use roll::RollState;
#[cfg(test)]
use roll::{roll_force_n, roll_normal_n, LAMBDA_S_PER_M};

/// RMS surface height in metres at `roughness = 1`: 10 µm is coarse sandpaper / rough-sawn wood;
/// roughness 0..1 maps linearly to 0..10 µm RMS.
pub const MAX_RMS_HEIGHT_M: f64 = 10e-6;
/// Default grain size: 50 µm, fine sandpaper grit / wood fibre scale.
pub const DEFAULT_GRAIN_M: f64 = 50e-6;
/// Default spectral exponent of the height spectrum: β = 4, a profile whose *slope* is
/// Brownian. Why: the scraping force is `m_p·S̈`, whose spectrum is the curvature's,
/// `∝ k^(4−β)`; only at β = 4 is it flat over the audio band (up to the tip's smoothing and the
/// grain), so that, as for an impact, the object's modes and not the force decide where the
/// energy lies. With a Brownian height (β = 2) the force rose as f² into the smoothing corner
/// (a band around 2–3 kHz at 0.5 m/s) and every object's scrape had that band's centroid:
/// wood and metal measured 1.5–2.1 kHz alike.
pub const DEFAULT_BETA: f64 = 4.0;
pub use crate::engine::limits::{MAX_CONTACT_SPEED_M_PER_S as MAX_SPEED_M_PER_S, MAX_PRESSURE_N};
/// Effective contact modulus E* of the reference contact, Pa: 2 GPa, the hard (steel) scraper tip
/// or ball on a plank across the grain (E ≈ 1–2 GPa) or on a polymer. The scraping smoothing's
/// reference width ([`trajectory::SMOOTHING_REF_SPEED_M_PER_S`]) and the level calibration's
/// reference force spectra ([`channel::scrape_ref_weight`], [`channel::roll_ref_weight`]) are
/// this contact's.
pub const REF_CONTACT_MODULUS_PA: f64 = 2.0e9;

/// Effective contact modulus E* of the steel tip or ball on an object of `material_class`, Pa:
/// `1/E* = (1−ν₁²)/E₁ + (1−ν₂²)/E₂` with steel (E₁ = 200 GPa, ν₁ = 0.29) and a representative
/// surface (docs/model.md §6): bronze/brass/steel 110 GPa, ν 0.34 → 80 GPa; soda-lime glass and
/// porcelain 70 GPa, ν 0.22 → 55 GPa; granite/marble 50 GPa, ν 0.25 → 43 GPa; a rigid polymer
/// (ABS, polystyrene) → 3 GPa; wood across the grain → the reference. Why per material: the
/// patch (and so the smoothing of the surface it scrapes or rolls over) narrows as `E*^(−1/3)`,
/// which is what makes a scrape on metal brighter than one on wood with the same tip. Other
/// classes (cardboard, whose crushable board is no Hertzian solid, and custom ones) keep the
/// reference.
pub fn contact_modulus_pa(material_class: &str) -> f64 {
    let c = material_class.trim();
    let is = |name: &str| c.eq_ignore_ascii_case(name);
    if is("metal") {
        80.0e9
    } else if is("glass") || is("ceramic") {
        55.0e9
    } else if is("stone") {
        43.0e9
    } else if is("plastic") {
        3.0e9
    } else {
        REF_CONTACT_MODULUS_PA
    }
}

/// Width of a Hertzian contact patch on a surface of effective modulus `modulus_pa` relative to
/// the reference contact's at the same load and radius, `(E*_ref/E*)^(1/3)` (Johnson, *Contact
/// Mechanics*, §4.2). A modulus that is not finite and positive gives 1 (the reference).
pub fn patch_scale(modulus_pa: f64) -> f64 {
    if modulus_pa.is_finite() && modulus_pa > 0.0 {
        (REF_CONTACT_MODULUS_PA / modulus_pa).cbrt()
    } else {
        1.0
    }
}

/// Onset fade: 5 ms, long enough that the first samples of a new contact do not click, short
/// enough to keep the attack of a stroke.
pub const ONSET_FADE_S: f64 = 0.005;

/// What the voice generates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ContactKind {
    /// A scraper moved by a [`MotionKind`].
    #[default]
    Scrape,
    /// An eccentric ball rolling straight at `roll_speed_m_per_s`.
    Roll,
}

/// Per-block controls in physical units: the engine builds them from its settings
/// ([`SustainedParams::scrape`], [`SustainedParams::roll`]) and adds the force laws' constants.
/// Non-finite values are treated as 0 / defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SustainedParams {
    /// Scrape or roll.
    pub kind: ContactKind,
    /// Scraping motion.
    pub motion: MotionKind,
    /// Scraping speed in m/s (peak speed of the motion; constant speed for circular/manual).
    pub scrape_speed_m_per_s: f64,
    /// Mean normal force in N (scrape pressure or the ball's weight m·g).
    pub pressure_n: f64,
    /// Surface roughness 0..1 → RMS height 0..[`MAX_RMS_HEIGHT_M`] of the synthetic surface.
    pub roughness: f64,
    /// The surface: synthetic (with `roughness`) or a measured one (its own heights).
    pub surface: SurfaceKind,
    /// Ball centre speed in m/s.
    pub roll_speed_m_per_s: f64,
    /// Ball mean radius R in m (1 mm..1 m).
    pub roll_radius_m: f64,
    /// Centre-of-mass offset r/R (0..0.5).
    pub roll_eccentricity: f64,
    /// Scraping force law (probe mass, β1, β2).
    pub law: ScrapeLaw,
    /// k of the rolling term in N/m^(3/2).
    pub roll_k: f64,
}

impl Default for SustainedParams {
    fn default() -> Self {
        Self {
            kind: ContactKind::Scrape,
            motion: MotionKind::Manual,
            scrape_speed_m_per_s: 0.3,
            pressure_n: 5.0,
            roughness: 0.5,
            surface: SurfaceKind::Synthetic,
            roll_speed_m_per_s: 0.5,
            roll_radius_m: 0.02,
            roll_eccentricity: 0.1,
            law: ScrapeLaw::default(),
            roll_k: roll::DEFAULT_K_N_PER_M1_5,
        }
    }
}

impl SustainedParams {
    /// The scraping voice's input: the settings' scrape group, the rest at its defaults.
    pub fn scrape(p: &ScrapeParams) -> Self {
        Self {
            kind: ContactKind::Scrape,
            motion: p.motion,
            scrape_speed_m_per_s: p.speed_m_per_s,
            pressure_n: p.pressure_n,
            roughness: p.roughness,
            surface: p.surface,
            ..Self::default()
        }
    }

    /// The rolling voice's input: the settings' roll group, the rest at its defaults.
    pub fn roll(p: &RollParams) -> Self {
        Self {
            kind: ContactKind::Roll,
            roll_speed_m_per_s: p.speed_m_per_s,
            pressure_n: p.pressure_n,
            roughness: p.roughness,
            surface: p.surface,
            roll_radius_m: p.radius_m,
            roll_eccentricity: p.eccentricity,
            ..Self::default()
        }
    }
}

fn finite_or(x: f64, d: f64) -> f64 {
    if x.is_finite() {
        x
    } else {
        d
    }
}

/// One scraping or rolling contact: owns surface, motion, trajectory and roll state.
#[derive(Debug, Clone)]
pub struct SustainedVoice {
    fs: f64,
    dt: f64,
    surface: Surface,
    /// The measured surfaces' endless profile (selected per block from the params).
    measured: MeasuredSurface,
    motion: Motion,
    traj: Trajectory,
    roll: RollState,
    patch: roll::HertzPatch,
    /// Effective modulus of the tip or ball on the object, Pa ([`contact_modulus_pa`]).
    contact_modulus_pa: f64,
    x_m: f64,
    y_m: f64,
    active: bool,
    fade: f64,
    fade_step: f64,
    last_normal_n: f64,
    computed: u64,
    /// The SIMD variant of the vectorised roll kinematics (detected once).
    simd: crate::engine::dsp::simd::Kernel,
    /// Ablation: `false` bypasses the tanh curvature limit and its Gaussian smoothing.
    pub curvature_limit: bool,
    /// Ablation: `false` holds N at the mean pressure (no motion/rotation swing of α).
    pub varying_normal_force: bool,
}

impl SustainedVoice {
    /// Builds a voice (allocates): surface from `seed` with the default grain and β.
    pub fn new(sample_rate_hz: f64, seed: u64) -> Self {
        let mut v = Self {
            fs: 48_000.0,
            dt: 1.0 / 48_000.0,
            surface: Surface::new(seed, DEFAULT_GRAIN_M, DEFAULT_BETA),
            measured: MeasuredSurface::new(seed),
            motion: Motion::new(sample_rate_hz, seed),
            traj: Trajectory::default(),
            roll: RollState::default(),
            patch: roll::HertzPatch::default(),
            contact_modulus_pa: REF_CONTACT_MODULUS_PA,
            x_m: 0.0,
            y_m: 0.0,
            active: false,
            fade: 0.0,
            fade_step: 1.0,
            last_normal_n: 0.0,
            computed: 0,
            simd: crate::engine::dsp::simd::Kernel::detect(),
            curvature_limit: true,
            varying_normal_force: true,
        };
        v.prepare(sample_rate_hz);
        v
    }

    /// Sets the sample rate (allocates the smoothing kernels) and resets.
    pub fn prepare(&mut self, sample_rate_hz: f64) {
        self.traj.prepare(sample_rate_hz);
        self.fs = self.traj.sample_rate();
        self.dt = 1.0 / self.fs;
        self.motion.set_sample_rate(self.fs);
        self.fade_step = 1.0 / (ONSET_FADE_S * self.fs);
        self.reset();
    }

    /// Replaces the surface (allocates, runs an FFT: call off the audio thread).
    pub fn set_surface(&mut self, seed: u64, grain_m: f64, beta: f64) {
        self.surface = Surface::new(seed, grain_m, beta);
        self.measured.reseed(seed);
        self.motion.reseed(seed);
        self.traj.reprime();
    }

    /// Sets the effective modulus of the tip or ball on the object ([`contact_modulus_pa`]):
    /// the scraping smoothing and the rolling patch narrow as `E*^(−1/3)`. A value that is not
    /// finite and positive keeps the reference contact. Never allocates.
    pub fn set_contact_modulus(&mut self, modulus_pa: f64) {
        self.contact_modulus_pa = if modulus_pa.is_finite() && modulus_pa > 0.0 {
            modulus_pa
        } else {
            REF_CONTACT_MODULUS_PA
        };
        self.traj.set_patch_scale(patch_scale(self.contact_modulus_pa));
    }

    /// The effective modulus of the tip or ball on the object, Pa ([`Self::set_contact_modulus`]).
    pub fn contact_modulus_pa(&self) -> f64 {
        self.contact_modulus_pa
    }

    /// The synthetic surface.
    pub fn surface(&self) -> &Surface {
        &self.surface
    }

    /// The measured surfaces' profile.
    pub fn measured(&self) -> &MeasuredSurface {
        &self.measured
    }

    /// Height in m at `x_m` of the selected surface (the synthetic one scaled by `rms_m`).
    #[inline]
    fn height_at(&mut self, x_m: f64, rms_m: f64) -> f64 {
        if self.measured.kind() == SurfaceKind::Synthetic {
            rms_m * self.surface.height(x_m)
        } else {
            self.measured.height_m(x_m)
        }
    }

    /// Clears all state: position 0, motion at t = 0 (never allocates).
    pub fn reset(&mut self) {
        self.traj.reset();
        self.motion.restart();
        self.roll = RollState::default();
        self.patch.reset();
        self.x_m = 0.0;
        self.y_m = 0.0;
        self.active = false;
        self.fade = 0.0;
        self.last_normal_n = 0.0;
    }

    /// Restarts the motion (e.g. a new note starts a new stroke) keeping the position.
    pub fn restart(&mut self) {
        self.motion.restart();
        self.roll = RollState::default();
        self.patch.reset();
        self.active = false;
    }

    /// Sample rate in Hz.
    pub fn sample_rate(&self) -> f64 {
        self.fs
    }

    /// Contact position (x, y) in metres.
    pub fn position_m(&self) -> (f64, f64) {
        (self.x_m, self.y_m)
    }

    /// Normal force of the last computed sample, N.
    pub fn last_normal_n(&self) -> f64 {
        self.last_normal_n
    }

    /// Samples computed since construction.
    pub fn samples_computed(&self) -> u64 {
        self.computed
    }

    /// The motion (read-only: time since start).
    pub fn motion(&self) -> &Motion {
        &self.motion
    }

    /// Writes one block of impulses (N·s per sample) into `impulse_out`; see the module docs.
    /// Returns whether anything was computed.
    pub fn process(
        &mut self,
        p: &SustainedParams,
        speed_input: Option<&[f32]>,
        impulse_out: &mut [f32],
    ) -> bool {
        let pressure = finite_or(p.pressure_n, 0.0).clamp(0.0, MAX_PRESSURE_N);
        let rms_m = finite_or(p.roughness, 0.0).clamp(0.0, 1.0) * MAX_RMS_HEIGHT_M;
        self.traj.curvature_limit = self.curvature_limit;
        if p.surface != self.measured.kind() {
            // Rewrites fixed-size tables only; the next contact starts from fresh heights.
            self.measured.select(p.surface);
            self.traj.reprime();
        }
        let live = match p.kind {
            ContactKind::Scrape => self.scrape_live(p, speed_input, pressure, impulse_out.len()),
            ContactKind::Roll => {
                pressure > 0.0
                    && match speed_input {
                        Some(s) => s
                            .iter()
                            .take(impulse_out.len())
                            .any(|v| *v != 0.0 && v.is_finite()),
                        None => finite_or(p.roll_speed_m_per_s, 0.0) != 0.0,
                    }
            }
        };
        if !live {
            if self.active {
                self.active = false;
                self.traj.reprime();
            }
            self.fade = 0.0;
            self.patch.reset();
            return false;
        }
        self.active = true;
        match p.kind {
            ContactKind::Scrape => self.run_scrape(p, speed_input, pressure, rms_m, impulse_out),
            ContactKind::Roll => self.run_roll(p, speed_input, pressure, rms_m, impulse_out),
        }
        self.computed += impulse_out.len() as u64;
        true
    }

    fn scrape_live(&self, p: &SustainedParams, speed_input: Option<&[f32]>, pressure: f64, n: usize) -> bool {
        if pressure <= 0.0 || n == 0 {
            return false;
        }
        match p.motion {
            MotionKind::Manual => match speed_input {
                Some(s) => s.iter().take(n).any(|v| *v != 0.0 && v.is_finite()),
                None => finite_or(p.scrape_speed_m_per_s, 0.0) != 0.0,
            },
            kind => {
                let v = finite_or(p.scrape_speed_m_per_s, 0.0);
                v != 0.0 && !self.motion.finished(kind, v.abs().min(MAX_SPEED_M_PER_S))
            }
        }
    }

    fn run_scrape(
        &mut self,
        p: &SustainedParams,
        speed_input: Option<&[f32]>,
        pressure: f64,
        rms_m: f64,
        out: &mut [f32],
    ) {
        let v = finite_or(p.scrape_speed_m_per_s, 0.0).clamp(-MAX_SPEED_M_PER_S, MAX_SPEED_M_PER_S);
        let two_d = matches!(p.motion, MotionKind::Circular | MotionKind::Scribble);
        let law = p.law;
        for (i, o) in out.iter_mut().enumerate() {
            let manual = match speed_input {
                Some(s) => s.get(i).map_or(0.0, |&x| finite_or(x as f64, 0.0)),
                None => v,
            }
            .clamp(-MAX_SPEED_M_PER_S, MAX_SPEED_M_PER_S);
            let m = self.motion.tick(p.motion, v, pressure, manual);
            let n = if self.varying_normal_force {
                m.normal_n
            } else {
                pressure
            };
            self.last_normal_n = n;
            if n <= 0.0 {
                // Lifted: no contact, and the next touch starts from a fresh height history.
                self.traj.reprime();
                self.x_m += m.vx_m_per_s * self.dt;
                self.y_m += m.vy_m_per_s * self.dt;
                *o = 0.0;
                continue;
            }
            self.x_m += m.vx_m_per_s * self.dt;
            self.y_m += m.vy_m_per_s * self.dt;
            let z = match (two_d, self.measured.kind() == SurfaceKind::Synthetic) {
                (true, true) => rms_m * self.surface.height_2d(self.x_m, self.y_m),
                (true, false) => self.measured.height_2d_m(self.x_m, self.y_m),
                (false, _) => self.height_at(self.x_m, rms_m),
            };
            let speed = (m.vx_m_per_s * m.vx_m_per_s + m.vy_m_per_s * m.vy_m_per_s).sqrt();
            let s = self.traj.tick(z, self.traj.alpha_for_pressure(n), speed);
            let f = law.total_n(&s);
            *o = self.emit(f);
        }
    }

    fn run_roll(
        &mut self,
        p: &SustainedParams,
        speed_input: Option<&[f32]>,
        pressure: f64,
        rms_m: f64,
        out: &mut [f32],
    ) {
        let v_const = finite_or(p.roll_speed_m_per_s, 0.0).clamp(-MAX_SPEED_M_PER_S, MAX_SPEED_M_PER_S);
        let radius = finite_or(p.roll_radius_m, 0.02).clamp(roll::MIN_RADIUS_M, roll::MAX_RADIUS_M);
        let ecc = finite_or(p.roll_eccentricity, 0.0).clamp(0.0, roll::MAX_ECCENTRICITY);
        let k = finite_or(p.roll_k, 0.0).max(0.0);
        let law = p.law;
        let consts = roll::RollConsts::new(pressure, radius, ecc, self.varying_normal_force);
        // The mass that follows the rolled surface is the ball itself (its weight is the mean
        // normal force), not a scraper tip: a heavier ball pushes harder on every asperity.
        let ball_mass_kg = pressure / motion::G_M_PER_S2;
        let mut kin = roll::RollBlock::default();
        for (c, chunk) in out.chunks_mut(roll::BLOCK).enumerate() {
            let n = chunk.len();
            // Pass 1: speeds and the angle (a serial running sum).
            for (i, w) in kin.theta_rate[..n].iter_mut().enumerate() {
                let v = match speed_input {
                    Some(s) => s
                        .get(c * roll::BLOCK + i)
                        .map_or(0.0, |&x| finite_or(x as f64, 0.0)),
                    None => v_const,
                }
                .clamp(-MAX_SPEED_M_PER_S, MAX_SPEED_M_PER_S);
                *w = v / radius;
            }
            self.roll.advance_block(&mut kin, n, self.dt);
            // Pass 2: the trigonometry and N for the whole chunk (no dependency between samples).
            roll::kinematics(self.simd, &consts, &mut kin, n);
            // Pass 3: contact positions and surface heights under the Hertzian patch.
            for i in 0..n {
                let cs = kin.contact_speed[i];
                self.x_m += cs * self.dt;
                let z = self.height_at(self.x_m, rms_m);
                kin.height[i] =
                    self.patch
                        .tick(z, kin.normal[i], cs, radius, self.contact_modulus_pa, self.dt);
            }
            // Pass 4: the trajectory (serial state).
            for i in 0..n {
                let s = self.traj.tick(
                    kin.height[i],
                    self.traj.alpha_for_pressure(kin.normal[i]),
                    kin.contact_speed[i],
                );
                (kin.traj_accel[i], kin.traj_vel[i], kin.traj_height[i]) =
                    (s.accel_m_per_s2, s.vel_m_per_s, s.height_m);
            }
            // Pass 5: the rolling term and the ball's m·S̈ (vectorised), then β1·Ṡ and the
            // onset fade.
            roll::forces(self.simd, &consts, k, ball_mass_kg, &mut kin, n);
            for (i, o) in chunk.iter_mut().enumerate() {
                let s = TrajectorySample {
                    accel_m_per_s2: 0.0,
                    vel_m_per_s: kin.traj_vel[i],
                    height_m: 0.0,
                };
                *o = self.emit(kin.force[i] + law.horizontal_n(&s));
            }
            self.last_normal_n = kin.normal[n - 1];
        }
    }

    /// The per-sample rolling loop the chunked [`Self::run_roll`] replaced: the reference of the
    /// equivalence test.
    #[cfg(test)]
    fn run_roll_reference(
        &mut self,
        p: &SustainedParams,
        speed_input: Option<&[f32]>,
        pressure: f64,
        rms_m: f64,
        out: &mut [f32],
    ) {
        let v_const = finite_or(p.roll_speed_m_per_s, 0.0).clamp(-MAX_SPEED_M_PER_S, MAX_SPEED_M_PER_S);
        let radius = finite_or(p.roll_radius_m, 0.02).clamp(roll::MIN_RADIUS_M, roll::MAX_RADIUS_M);
        let ecc = finite_or(p.roll_eccentricity, 0.0).clamp(0.0, roll::MAX_ECCENTRICITY);
        let k = finite_or(p.roll_k, 0.0).max(0.0);
        let law = p.law;
        for (i, o) in out.iter_mut().enumerate() {
            let v = match speed_input {
                Some(s) => s.get(i).map_or(0.0, |&x| finite_or(x as f64, 0.0)),
                None => v_const,
            }
            .clamp(-MAX_SPEED_M_PER_S, MAX_SPEED_M_PER_S);
            let kin = self.roll.advance(v, radius, ecc, self.dt);
            let n = if self.varying_normal_force {
                roll_normal_n(pressure, radius, ecc, &kin)
            } else {
                pressure
            };
            self.last_normal_n = n;
            self.x_m += kin.contact_speed_m_per_s * self.dt;
            let z = self.height_at(self.x_m, rms_m);
            let z = self.patch.tick(
                z,
                n,
                kin.contact_speed_m_per_s,
                radius,
                self.contact_modulus_pa,
                self.dt,
            );
            let s = self
                .traj
                .tick(z, self.traj.alpha_for_pressure(n), kin.contact_speed_m_per_s);
            let f = pressure / motion::G_M_PER_S2 * s.accel_m_per_s2
                + roll_force_n(k, LAMBDA_S_PER_M, radius, ecc, &kin, s.height_m, s.vel_m_per_s)
                + law.horizontal_n(&s);
            *o = self.emit(f);
        }
    }

    #[inline]
    fn emit(&mut self, f_n: f64) -> f32 {
        if self.fade < 1.0 {
            self.fade = (self.fade + self.fade_step).min(1.0);
        }
        let imp = (f_n * self.fade * self.dt) as f32;
        if imp.is_finite() {
            imp
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The patch narrows on stiffer surfaces and never widens past the reference; a modulus
    /// that is not finite and positive falls back to the reference contact (the voice's force
    /// is then the reference force, sample for sample).
    #[test]
    fn contact_modulus_orders_the_patches_and_bad_values_fall_back() {
        let k = |c: &str| patch_scale(contact_modulus_pa(c));
        assert_eq!(k("wood"), 1.0);
        assert_eq!(k("cardboard"), 1.0);
        assert_eq!(k(" Metal "), k("metal"));
        assert!(k("metal") < k("glass") && k("glass") < k("stone") && k("stone") < k("plastic"));
        assert!(k("plastic") < 1.0);
        for bad in [f64::NAN, f64::INFINITY, 0.0, -1.0] {
            assert_eq!(patch_scale(bad), 1.0);
        }
        let p = SustainedParams {
            kind: ContactKind::Scrape,
            motion: MotionKind::Manual,
            scrape_speed_m_per_s: 0.5,
            pressure_n: 5.0,
            ..Default::default()
        };
        let run = |modulus: Option<f64>| {
            let mut v = SustainedVoice::new(48_000.0, 7);
            if let Some(e) = modulus {
                v.set_contact_modulus(e);
            }
            let mut out = vec![0.0f32; 4096];
            v.process(&p, None, &mut out);
            out
        };
        let reference = run(None);
        assert_eq!(run(Some(f64::NAN)), reference);
        assert_eq!(run(Some(-5.0)), reference);
        assert_ne!(run(Some(contact_modulus_pa("metal"))), reference);
    }

    fn snr_db(a: &[f32], b: &[f32]) -> f64 {
        let sig: f64 = a.iter().map(|x| (*x as f64).powi(2)).sum();
        let err: f64 = a
            .iter()
            .zip(b)
            .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
            .sum();
        10.0 * (sig / err.max(1e-300)).log10()
    }

    /// The chunked rolling loop against the per-sample one it replaced, on constant speed,
    /// a speed ramp through zero, odd block sizes and strong eccentricity: the same force
    /// (≥ 100 dB SNR; the passes reorder no arithmetic, differences are rounding at most).
    #[test]
    fn chunked_roll_matches_per_sample_reference() {
        let ramp: Vec<f32> = (0..20_000).map(|i| i as f32 / 20_000.0 * 2.0 - 0.5).collect();
        let cases = [
            (
                SustainedParams {
                    kind: ContactKind::Roll,
                    ..Default::default()
                },
                false,
            ),
            (
                SustainedParams {
                    kind: ContactKind::Roll,
                    roll_eccentricity: 0.45,
                    roll_speed_m_per_s: 3.0,
                    roll_radius_m: 0.01,
                    pressure_n: 12.0,
                    ..Default::default()
                },
                false,
            ),
            (
                SustainedParams {
                    kind: ContactKind::Roll,
                    roll_radius_m: 0.05,
                    ..Default::default()
                },
                true,
            ),
        ];
        for (p, use_ramp) in cases {
            for block in [64usize, 37, 200] {
                let mut a = SustainedVoice::new(48_000.0, 9);
                let mut b = SustainedVoice::new(48_000.0, 9);
                let (mut ya, mut yb) = (vec![0.0f32; ramp.len()], vec![0.0f32; ramp.len()]);
                let mut pos = 0;
                while pos < ramp.len() {
                    let n = block.min(ramp.len() - pos);
                    let sp = use_ramp.then(|| &ramp[pos..pos + n]);
                    let pressure = p.pressure_n;
                    let rms = p.roughness * MAX_RMS_HEIGHT_M;
                    a.run_roll(&p, sp, pressure, rms, &mut ya[pos..pos + n]);
                    b.run_roll_reference(&p, sp, pressure, rms, &mut yb[pos..pos + n]);
                    pos += n;
                }
                assert!(ya.iter().all(|v| v.is_finite()));
                let snr = snr_db(&yb, &ya);
                assert!(snr > 100.0, "block {block}: SNR {snr} dB");
                assert_eq!(a.last_normal_n(), b.last_normal_n());
            }
        }
    }
}
