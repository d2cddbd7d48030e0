//! Hand motions for scraping: velocity profile and normal-force profile N(t) (docs/model.md §6,
//! Agarwal et al. 2021 §2.3 and Experiment 2's motions: back-and-forth, circular, straight
//! strokes, scribble, one long stroke; plus a manual mode driven by a per-sample speed input).
//!
//! Normal force: a cylinder held at angle θ, pushed along its length, with the hand accelerating
//! it horizontally (Agarwal §2.3): `N = (m·g + m·ẍ·L·tanθ)/(1 − μ·tanθ)`, ẍ the acceleration
//! away from the body. Scaled so that its mean is the `pressure` (the static term `m·g/(1−μ·tanθ)`):
//! `N(t) = pressure·(1 + L·tanθ·ẍ(t)/g)`, clamped at 0. Back-and-forth simple harmonic motion then
//! swings between the paper's `N_max` (near the body) and `N_min` (far end).
//! Positions in metres, velocities in m/s, forces in newtons.

use super::super::object::EngineRng;
use rand::{RngExt, SeedableRng};

/// Standard gravity in m/s².
pub const G_M_PER_S2: f64 = 9.806_65;
/// L·tanθ of the hand-held scraper: a 15 cm tool at 30° from the horizontal (a brush or sanding
/// block held at a typical angle); sets the depth of the N(t) swing for a given acceleration.
pub const LEVER_M: f64 = 0.15 * 0.577_350_269_189_625_8;
/// Half stroke of back-and-forth scraping: ±10 cm, a forearm stroke (sanding, scrubbing).
pub const BACK_AND_FORTH_HALF_M: f64 = 0.10;
/// Radius of circular scraping: 5 cm, a wrist-driven polishing circle.
pub const CIRCLE_RADIUS_M: f64 = 0.05;
/// Length of one straight stroke: 10 cm.
pub const STROKE_LENGTH_M: f64 = 0.10;
/// Lift between straight strokes: 150 ms, a quick return of the hand.
pub const STROKE_GAP_S: f64 = 0.15;
/// Strokes per line before the hand pauses (Agarwal: "four strokes in a line").
pub const STROKES_PER_LINE: usize = 4;
/// Pause after a line of strokes: 0.5 s, so the line repeats as a recognisable group.
pub const LINE_GAP_S: f64 = 0.5;
/// Length of the single long stroke: 60 cm, an arm's sweep.
pub const LONG_STROKE_M: f64 = 0.60;
/// Scribble component frequencies are drawn in this range (Hz): hand scribbling runs at a few
/// strokes per second.
pub const SCRIBBLE_RATE_HZ: (f64, f64) = (1.0, 4.0);
/// Peak speed of a minimum-jerk stroke is this times length/duration (Flash & Hogan profile).
pub const MIN_JERK_PEAK: f64 = 1.875;

/// The motion generating the scraper's path. In scene JSON: `"manual"`, `"back_and_forth"`,
/// `"circular"`, `"strokes"`, `"scribble"`, `"long_stroke"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MotionKind {
    /// Speed given per sample by the caller (automation); N = pressure.
    #[default]
    Manual,
    /// Simple harmonic motion along x, `±BACK_AND_FORTH_HALF_M`; speed zeros at both ends.
    BackAndForth,
    /// Constant speed around a circle of `CIRCLE_RADIUS_M`; no speed zeros.
    Circular,
    /// Lines of `STROKES_PER_LINE` minimum-jerk strokes, lifted between strokes.
    Strokes,
    /// A seeded sum of sinusoids on x and y: irregular speed with occasional near-zeros.
    Scribble,
    /// One minimum-jerk stroke of `LONG_STROKE_M`, then rest (inactive) until restarted.
    LongStroke,
}

/// One sample of a motion.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MotionSample {
    /// Velocity along x in m/s.
    pub vx_m_per_s: f64,
    /// Velocity along y in m/s.
    pub vy_m_per_s: f64,
    /// Normal force in N (0 = lifted).
    pub normal_n: f64,
}

/// Motion state (time since start plus the scribble's seeded components). Never allocates.
#[derive(Debug, Clone)]
pub struct Motion {
    t_s: f64,
    dt_s: f64,
    scribble: [(f64, f64); 6],
}

impl Motion {
    /// A motion at `sample_rate_hz`; `seed` draws the scribble.
    pub fn new(sample_rate_hz: f64, seed: u64) -> Self {
        let mut m = Self {
            t_s: 0.0,
            dt_s: 1.0 / 48_000.0,
            scribble: [(0.0, 0.0); 6],
        };
        m.set_sample_rate(sample_rate_hz);
        m.reseed(seed);
        m
    }

    /// Sets the sample rate in Hz.
    pub fn set_sample_rate(&mut self, sample_rate_hz: f64) {
        if sample_rate_hz.is_finite() && sample_rate_hz > 0.0 {
            self.dt_s = 1.0 / sample_rate_hz;
        }
    }

    /// Redraws the scribble components (angular rate rad/s, phase rad).
    pub fn reseed(&mut self, seed: u64) {
        let mut rng = EngineRng::seed_from_u64(seed ^ 0x5c21_bb1e_0000_0003);
        for c in self.scribble.iter_mut() {
            let f = SCRIBBLE_RATE_HZ.0 + (SCRIBBLE_RATE_HZ.1 - SCRIBBLE_RATE_HZ.0) * rng.random::<f64>();
            *c = (
                std::f64::consts::TAU * f,
                std::f64::consts::TAU * rng.random::<f64>(),
            );
        }
    }

    /// Restarts the motion from t = 0.
    pub fn restart(&mut self) {
        self.t_s = 0.0;
    }

    /// Time since the start in seconds.
    pub fn time_s(&self) -> f64 {
        self.t_s
    }

    /// True once a [`MotionKind::LongStroke`] has ended at `speed_m_per_s`.
    pub fn finished(&self, kind: MotionKind, speed_m_per_s: f64) -> bool {
        kind == MotionKind::LongStroke && self.t_s >= min_jerk_duration_s(LONG_STROKE_M, speed_m_per_s)
    }

    /// Advances one sample. `speed_m_per_s` is the peak speed (constant speed for `Circular`);
    /// `manual_m_per_s` the signed per-sample speed used by `Manual`; `pressure_n` the mean N.
    #[inline]
    pub fn tick(
        &mut self,
        kind: MotionKind,
        speed_m_per_s: f64,
        pressure_n: f64,
        manual_m_per_s: f64,
    ) -> MotionSample {
        let t = self.t_s;
        self.t_s += self.dt_s;
        let v = speed_m_per_s.abs();
        let p = pressure_n.max(0.0);
        let n_of = |ax: f64| (p * (1.0 + LEVER_M * ax / G_M_PER_S2)).max(0.0);
        match kind {
            MotionKind::Manual => MotionSample {
                vx_m_per_s: manual_m_per_s,
                vy_m_per_s: 0.0,
                normal_n: p,
            },
            MotionKind::BackAndForth => {
                // x = −A·cos(ωt): starts at the near end, at rest; v̂ = A·ω.
                let w = v / BACK_AND_FORTH_HALF_M;
                let (s, c) = crate::engine::dsp::trig::fast_sin_cos(w * t);
                let vx = v * s;
                let ax = v * w * c;
                MotionSample {
                    vx_m_per_s: vx,
                    vy_m_per_s: 0.0,
                    normal_n: n_of(ax),
                }
            }
            MotionKind::Circular => {
                let w = v / CIRCLE_RADIUS_M;
                let (s, c) = crate::engine::dsp::trig::fast_sin_cos(w * t);
                MotionSample {
                    vx_m_per_s: -v * s,
                    vy_m_per_s: v * c,
                    normal_n: n_of(-v * w * c),
                }
            }
            MotionKind::Strokes => {
                let d = min_jerk_duration_s(STROKE_LENGTH_M, v);
                let line = STROKES_PER_LINE as f64 * (d + STROKE_GAP_S) + LINE_GAP_S;
                let tl = t % line;
                let ts = tl % (d + STROKE_GAP_S);
                if tl >= STROKES_PER_LINE as f64 * (d + STROKE_GAP_S) || ts >= d {
                    MotionSample::default()
                } else {
                    let (vx, ax) = min_jerk(STROKE_LENGTH_M, d, ts);
                    MotionSample {
                        vx_m_per_s: vx,
                        vy_m_per_s: 0.0,
                        normal_n: n_of(ax),
                    }
                }
            }
            MotionKind::Scribble => {
                let (mut vx, mut vy, mut ax) = (0.0, 0.0, 0.0);
                for (i, &(w, ph)) in self.scribble.iter().enumerate() {
                    let (s, c) = crate::engine::dsp::trig::fast_sin_cos(w * t + ph);
                    if i < 3 {
                        vx += c;
                        ax -= w * s;
                    } else {
                        vy += c;
                    }
                }
                // Each axis is a sum of three unit cosines: /3 keeps each axis within ±v.
                let k = v / 3.0;
                MotionSample {
                    vx_m_per_s: k * vx,
                    vy_m_per_s: k * vy,
                    normal_n: n_of(k * ax),
                }
            }
            MotionKind::LongStroke => {
                let d = min_jerk_duration_s(LONG_STROKE_M, v);
                if t >= d {
                    MotionSample::default()
                } else {
                    let (vx, ax) = min_jerk(LONG_STROKE_M, d, t);
                    MotionSample {
                        vx_m_per_s: vx,
                        vy_m_per_s: 0.0,
                        normal_n: n_of(ax),
                    }
                }
            }
        }
    }
}

/// Duration in s of a minimum-jerk stroke of `length_m` with peak speed `peak_m_per_s`.
pub fn min_jerk_duration_s(length_m: f64, peak_m_per_s: f64) -> f64 {
    if peak_m_per_s > 1e-9 {
        MIN_JERK_PEAK * length_m / peak_m_per_s
    } else {
        f64::INFINITY
    }
}

/// Velocity (m/s) and acceleration (m/s²) of a minimum-jerk stroke at time `t_s` of `dur_s`.
fn min_jerk(length_m: f64, dur_s: f64, t_s: f64) -> (f64, f64) {
    let tau = (t_s / dur_s).clamp(0.0, 1.0);
    let v = length_m / dur_s * 30.0 * tau * tau * (1.0 - tau) * (1.0 - tau);
    let a = length_m / (dur_s * dur_s) * (60.0 * tau - 180.0 * tau * tau + 120.0 * tau * tau * tau);
    (v, a)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_jerk_peak_and_length() {
        let d = min_jerk_duration_s(0.1, 0.5);
        let n = 10_000;
        let (mut dist, mut peak) = (0.0, 0.0f64);
        for i in 0..n {
            let (v, _) = min_jerk(0.1, d, (i as f64 + 0.5) * d / n as f64);
            dist += v * d / n as f64;
            peak = peak.max(v);
        }
        assert!((dist - 0.1).abs() < 1e-6);
        assert!((peak - 0.5).abs() < 1e-3);
    }
}
