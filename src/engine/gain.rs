//! The engine's output gain: a click-free linear ramp (in amplitude) to each new `gain_db`,
//! applied after the synthesis to everything that sounds. Never allocates.

use super::Lifecycle;

/// Length of the output gain's ramp after a change of `gain_db`: 10 ms. Why: a step in gain
/// on a ringing mode is a click; 10 ms is below the ~20 ms a listener hears as a fade and well
/// inside the 50 ms within which a turned-down gain must have taken effect.
pub const GAIN_RAMP_S: f64 = 0.010;

/// The smoothed output gain: a linear ramp (in amplitude) of [`GAIN_RAMP_S`] to each new target.
#[derive(Debug, Clone, Copy)]
pub(super) struct OutputGain {
    /// Sample rate (Hz) the ramp length is counted in.
    sample_rate_hz: f64,
    /// Gain now (linear); `None` until the first block, which starts at its target (no fade-in
    /// from an arbitrary gain).
    now: Option<f64>,
    /// Target of the running ramp, dB (a new target restarts the ramp).
    target_db: f64,
    target: f64,
    step: f64,
    left: u64,
}

impl OutputGain {
    pub(super) fn new(sample_rate_hz: f64) -> Self {
        Self {
            sample_rate_hz,
            now: None,
            target_db: 0.0,
            target: 1.0,
            step: 0.0,
            left: 0,
        }
    }

    /// Sets the target gain in dB; a change starts a [`GAIN_RAMP_S`] ramp from the gain now.
    pub(super) fn set_target(&mut self, gain_db: f64) {
        if self.now.is_some() && gain_db == self.target_db {
            return;
        }
        self.target_db = gain_db;
        self.target = 10f64.powf(gain_db / 20.0);
        match self.now {
            None => {
                self.now = Some(self.target);
                self.left = 0;
            }
            Some(now) => {
                self.left = (GAIN_RAMP_S * self.sample_rate_hz).round().max(1.0) as u64;
                self.step = (self.target - now) / self.left as f64;
            }
        }
    }

    /// Multiplies `out` by the ramped gain (or only advances the ramp when `out` is silent).
    #[inline]
    pub(super) fn apply(&mut self, out: &mut [f32], silent: bool) {
        let Some(mut now) = self.now else { return };
        if self.left == 0 {
            if !silent && now != 1.0 {
                let g = now as f32;
                out.iter_mut().for_each(|o| *o *= g);
            }
            return;
        }
        let ramp = (self.left.min(out.len() as u64)) as usize;
        if silent {
            now += self.step * ramp as f64;
        } else {
            for o in &mut out[..ramp] {
                now += self.step;
                *o *= now as f32;
            }
        }
        self.left -= ramp as u64;
        if self.left == 0 {
            now = self.target;
            if !silent {
                let g = now as f32;
                out[ramp..].iter_mut().for_each(|o| *o *= g);
            }
        }
        self.now = Some(now);
    }
}

impl Lifecycle for OutputGain {
    fn prepare(&mut self, sample_rate_hz: f64, _max_block: usize) {
        self.sample_rate_hz = sample_rate_hz;
    }

    /// Nothing sounds after a reset: the next block starts at its gain without a ramp.
    fn reset(&mut self) {
        *self = Self::new(self.sample_rate_hz);
    }
}
