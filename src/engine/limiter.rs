//! The output limiter: a stereo-linked peak limiter without look-ahead, so no sample leaves above
//! [`CEILING`] and nothing is delayed (no latency to report). Where the signal stays under the
//! ceiling and the gain is back at 1, it touches no sample: quiet material passes bit-identical.
//!
//! The gain follows the classic instantaneous-attack peak limiter (Zölzer, *DAFX*, 2nd ed.,
//! §4.2.2, with the attack made instantaneous): a sample whose peak over both channels times the
//! gain would exceed the ceiling sets the gain to exactly `ceiling / peak`; the gain then holds
//! for [`HOLD_S`] and returns to 1 along a one-pole curve of time constant [`RELEASE_S`], and is
//! set to exactly 1 once within [`SNAP`] of it. Both channels get the same gain, so the stereo
//! image does not move. A final clamp to ±ceiling removes the one-ulp excess the division's
//! rounding can leave.
//!
//! Lifecycle as every engine part ([`Lifecycle`]): [`Limiter::new`] / `prepare` set the sample
//! rate; `reset`, [`Limiter::process_stereo`], [`Limiter::process_mono`] and [`Limiter::skip`]
//! never allocate, lock or panic. Non-finite input samples (NaN, ±inf) are written as 0 and do
//! not move the gain: the output is always finite.

use super::Lifecycle;

/// The ceiling in dBFS: −0.3 dB, the usual margin under full scale that leaves room for the
/// inter-sample overshoot of a DAC's reconstruction filter on anything but pathological signals.
pub const CEILING_DBFS: f64 = -0.3;

/// The ceiling as a linear amplitude: 10^(−0.3/20) rounded to the nearest f32 (the test
/// `ceiling_is_minus_0_3_dbfs` checks it is exactly that f32). No output sample's magnitude exceeds it.
pub const CEILING: f32 = 0.966_050_86;

/// How long the gain holds after the last sample that lowered it (s). Why 10 ms: a steady tone's
/// peaks recur every half period, and holding across the half period of 50 Hz keeps the gain
/// from rising and falling between them (which would distort a low, loud tone).
pub const HOLD_S: f64 = 0.010;

/// Time constant of the release toward unity gain after the hold (s). Why 100 ms: slow enough
/// that the release does not audibly modulate a decaying resonance, fast enough that the level
/// comes back between strikes played at a few per second.
pub const RELEASE_S: f64 = 0.100;

/// Distance from unity at which the released gain is set to exactly 1: a 1e-6 step (−120 dB) is
/// inaudible, and from then on the limiter passes samples untouched.
pub const SNAP: f64 = 1e-6;

/// The limiter's state: its gain and what remains of the hold.
#[derive(Debug, Clone, Copy)]
pub struct Limiter {
    /// Gain applied now, in [0, 1]. f64: in f32 the release would stall about 1e-4 under 1,
    /// where a step of `(1 − gain)·(1 − release_coef)` falls under half an ulp of the gain.
    gain: f64,
    /// Samples of hold left before the gain starts to rise.
    hold_left: u32,
    /// [`HOLD_S`] in samples.
    hold_samples: u32,
    /// Per-sample factor on the distance `1 − gain` during the release.
    release_coef: f64,
    /// Smallest gain since the last [`Limiter::take_min_gain`] (meters, tests).
    min_gain: f32,
}

impl Limiter {
    /// A limiter at unity gain for `sample_rate_hz` (non-finite or non-positive rates fall back
    /// to 48 kHz).
    pub fn new(sample_rate_hz: f64) -> Self {
        let mut l = Self {
            gain: 1.0,
            hold_left: 0,
            hold_samples: 0,
            release_coef: 0.0,
            min_gain: 1.0,
        };
        l.prepare(sample_rate_hz, 0);
        l
    }

    /// The gain applied now (1 = untouched).
    pub fn gain(&self) -> f32 {
        self.gain as f32
    }

    /// The smallest gain applied since the previous call (1 when the limiter did nothing), and
    /// starts the next interval at the gain now.
    pub fn take_min_gain(&mut self) -> f32 {
        let m = self.min_gain;
        self.min_gain = self.gain as f32;
        m
    }

    /// The gain for the next sample, whose peak over the channels is `peak` (finite, ≥ 0).
    #[inline]
    fn next_gain(&mut self, peak: f32) -> f32 {
        if self.gain < 1.0 {
            if self.hold_left > 0 {
                self.hold_left -= 1;
            } else {
                self.gain = 1.0 - (1.0 - self.gain) * self.release_coef;
                if 1.0 - self.gain < SNAP {
                    self.gain = 1.0;
                }
            }
        }
        // The test and the multiplication are in f32, as the samples: a gain that passes the
        // test keeps `peak · g` at or under the ceiling.
        let mut g = self.gain as f32;
        if peak * g > CEILING {
            g = CEILING / peak;
            self.gain = g as f64;
            self.hold_left = self.hold_samples;
        }
        self.min_gain = self.min_gain.min(g);
        g
    }

    /// Limits a stereo block in place (`l` and `r` of equal length; a longer channel's excess is
    /// left as it is).
    pub fn process_stereo(&mut self, l: &mut [f32], r: &mut [f32]) {
        let n = l.len().min(r.len());
        let (l, r) = (&mut l[..n], &mut r[..n]);
        // The common case, gain at 1 and nothing above the ceiling, reads the block and writes
        // nothing. `!(|x| <= ceiling)` also catches NaN.
        if self.gain == 1.0 && l.iter().chain(r.iter()).all(|x| x.abs() <= CEILING) {
            return;
        }
        for (a, b) in l.iter_mut().zip(r.iter_mut()) {
            let (x, y) = (finite(*a), finite(*b));
            let g = self.next_gain(x.abs().max(y.abs()));
            if g == 1.0 {
                (*a, *b) = (x, y);
            } else {
                *a = (x * g).clamp(-CEILING, CEILING);
                *b = (y * g).clamp(-CEILING, CEILING);
            }
        }
    }

    /// Limits a mono block in place.
    pub fn process_mono(&mut self, x: &mut [f32]) {
        if self.gain == 1.0 && x.iter().all(|v| v.abs() <= CEILING) {
            return;
        }
        for v in x.iter_mut() {
            let s = finite(*v);
            let g = self.next_gain(s.abs());
            *v = if g == 1.0 {
                s
            } else {
                (s * g).clamp(-CEILING, CEILING)
            };
        }
    }

    /// Advances the state over `n` samples of silence without reading them: exactly what
    /// processing `n` zeros does (the hold runs down, then the gain releases), in closed form.
    pub fn skip(&mut self, n: usize) {
        if self.gain == 1.0 || n == 0 {
            return;
        }
        let n = n.min(u32::MAX as usize) as u32;
        let held = n.min(self.hold_left);
        self.hold_left -= held;
        let rest = n - held;
        if rest == 0 {
            return;
        }
        // Step by step the snap may fire before the last sample; the closed form reaches at
        // least as close to 1 and then snaps, so both end at 1 once within SNAP.
        let mut g = 1.0 - (1.0 - self.gain) * self.release_coef.powi(rest.min(i32::MAX as u32) as i32);
        if 1.0 - g < SNAP {
            g = 1.0;
        }
        self.gain = g;
    }
}

impl Lifecycle for Limiter {
    fn prepare(&mut self, sample_rate_hz: f64, _max_block: usize) {
        let sr = if sample_rate_hz.is_finite() && sample_rate_hz > 0.0 {
            sample_rate_hz
        } else {
            48_000.0
        };
        self.hold_samples = (HOLD_S * sr).round().min(u32::MAX as f64) as u32;
        self.release_coef = (-1.0 / (RELEASE_S * sr)).exp();
        self.reset();
    }

    fn reset(&mut self) {
        self.gain = 1.0;
        self.hold_left = 0;
        self.min_gain = 1.0;
    }
}

/// `x`, or 0 when it is NaN or infinite.
#[inline]
fn finite(x: f32) -> f32 {
    if x.is_finite() {
        x
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SR: f64 = 48_000.0;

    /// A stereo test signal: two sines of peak `amp` at unrelated frequencies.
    fn tone(n: usize, amp: f32) -> (Vec<f32>, Vec<f32>) {
        let s = |f: f64, i: usize| amp * (std::f64::consts::TAU * f * i as f64 / SR).sin() as f32;
        (
            (0..n).map(|i| s(441.0, i)).collect(),
            (0..n).map(|i| s(97.3, i)).collect(),
        )
    }

    fn peak(x: &[f32]) -> f32 {
        x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
    }

    #[test]
    fn ceiling_is_minus_0_3_dbfs() {
        assert_eq!(CEILING, 10f64.powf(CEILING_DBFS / 20.0) as f32);
        const { assert!(CEILING < 1.0) };
    }

    #[test]
    fn a_signal_6_db_under_the_ceiling_passes_bit_identical() {
        let amp = CEILING * 10f32.powf(-6.0 / 20.0);
        let (l0, r0) = tone(48_000, amp);
        let (mut l, mut r) = (l0.clone(), r0.clone());
        let mut lim = Limiter::new(SR);
        for (a, b) in l.chunks_mut(333).zip(r.chunks_mut(333)) {
            lim.process_stereo(a, b);
        }
        assert_eq!(
            l.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            l0.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(
            r.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            r0.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(lim.take_min_gain(), 1.0);
        let mut m = l0.clone();
        lim.process_mono(&mut m);
        assert!(m.iter().zip(&l0).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn a_70_dbfs_burst_never_exceeds_the_ceiling_and_quiet_material_returns_untouched() {
        let loud = 10f32.powf(70.0 / 20.0);
        let (mut l, mut r) = tone(4_800, loud);
        // A click of the largest finite value, on one channel only.
        l[100] = f32::MAX;
        r[2000] = -f32::MAX;
        let mut lim = Limiter::new(SR);
        lim.process_stereo(&mut l, &mut r);
        assert!(
            peak(&l) <= CEILING && peak(&r) <= CEILING,
            "{} {}",
            peak(&l),
            peak(&r)
        );
        // Limited, not silenced: the burst comes out near the ceiling.
        assert!(peak(&l) > 0.9 * CEILING);
        assert!(lim.take_min_gain() < 1e-30);
        // After the hold and release the gain is exactly 1 again, and quiet material passes
        // untouched.
        let (mut q, mut z) = tone(96_000, 0.1);
        lim.process_stereo(&mut q, &mut z);
        let (q0, _) = tone(48_000, 0.1);
        let (mut q2, mut z2) = (q0.clone(), q0.clone());
        lim.process_stereo(&mut q2, &mut z2);
        assert_eq!(lim.gain(), 1.0);
        assert!(q2.iter().zip(&q0).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn the_gain_holds_then_releases_smoothly() {
        let mut lim = Limiter::new(SR);
        let (mut l, mut r) = (vec![0.0f32; 48_000], vec![0.0f32; 48_000]);
        l[0] = 2.0 * CEILING;
        lim.process_stereo(&mut l[..1], &mut r[..1]);
        assert_eq!(lim.gain(), 0.5);
        let hold = (HOLD_S * SR) as usize;
        let mut gains = Vec::new();
        for i in 1..48_000 {
            l[i] = 0.5;
            lim.process_stereo(&mut l[i..i + 1], &mut r[i..i + 1]);
            gains.push(lim.gain());
        }
        assert!(gains[..hold].iter().all(|&g| g == 0.5), "held");
        assert!(gains[hold] > 0.5, "released after the hold");
        assert!(gains.windows(2).all(|w| w[1] >= w[0]), "monotone release");
        // One time constant after the hold, 1 − g has fallen by e.
        let g = gains[hold + (RELEASE_S * SR) as usize];
        assert!(((1.0 - g) / 0.5 - (-1.0f32).exp()).abs() < 1e-3, "{g}");
        assert!(gains.windows(2).all(|w| w[1] - w[0] < 1e-3), "no jumps");
    }

    #[test]
    fn non_finite_input_becomes_zero_and_leaves_the_gain_alone() {
        let mut l = vec![0.25, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.5];
        let mut r = vec![f32::NAN, 0.1, 0.2, 0.3, f32::NAN];
        let mut lim = Limiter::new(SR);
        lim.process_stereo(&mut l, &mut r);
        assert_eq!(l, [0.25, 0.0, 0.0, 0.0, 0.5]);
        assert_eq!(r, [0.0, 0.1, 0.2, 0.3, 0.0]);
        assert_eq!(lim.gain(), 1.0);
        let mut m = vec![f32::NAN, 3.0, f32::INFINITY];
        lim.process_mono(&mut m);
        assert!(m.iter().all(|v| v.is_finite() && v.abs() <= CEILING), "{m:?}");
        assert_eq!(m[0], 0.0);
    }

    #[test]
    fn blocks_of_any_size_give_the_same_samples() {
        let (l0, r0) = tone(20_000, 5.0);
        let run = |block: usize| {
            let (mut l, mut r) = (l0.clone(), r0.clone());
            let mut lim = Limiter::new(SR);
            for (a, b) in l.chunks_mut(block).zip(r.chunks_mut(block)) {
                lim.process_stereo(a, b);
            }
            (l, r)
        };
        let whole = run(20_000);
        for block in [1, 64, 333] {
            assert_eq!(run(block), whole, "block {block}");
        }
    }

    #[test]
    fn skip_matches_processing_silence() {
        for n in [1usize, 100, 480, 481, 5_000, 200_000] {
            let mut a = Limiter::new(SR);
            let (mut l, mut r) = (vec![4.0f32], vec![0.0f32]);
            a.process_stereo(&mut l, &mut r);
            let mut b = a;
            let (mut zl, mut zr) = (vec![0.0f32; n], vec![0.0f32; n]);
            // Silence with the gain below 1 takes the per-sample path.
            a.process_stereo(&mut zl, &mut zr);
            b.skip(n);
            assert!(
                (a.gain() - b.gain()).abs() < 1e-6,
                "n = {n}: {} vs {}",
                a.gain(),
                b.gain()
            );
            assert_eq!(a.gain() == 1.0, b.gain() == 1.0, "n = {n}");
        }
    }
}
