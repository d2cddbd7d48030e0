//! Stereo pickups (docs/model.md "Stereo pickups"): every mode of an object reaches the left
//! and right pickup with gains `g·(1 + w·s)` and `g·(1 − w·s)`, where `g` is its mono gain,
//! `w` the `width` setting and `s` its side weight, drawn per mode from its own stream.
//!
//! Why this gain model:
//! - **The sum is the mono pickup.** `L + R = 2·mono` at every width, mode by mode: a stereo
//!   render folds down to exactly the width-0 render (no comb cancellation, no level change in
//!   mono). So `s` is a balance, never a sign flip: `|w·s| ≤ 1` keeps both gains ≥ 0.
//! - **Width 1 is two independent pickups.** Two pickups at independent points see a mode with
//!   independent mode-shape values `a`, `b` (Gaussian over random points). Keeping their
//!   magnitudes (signs dropped, so the sum never cancels) and their sum (the mono gain), the
//!   mode's balance is `s = (|a| − |b|)/(|a| + |b|) = tan φ` with `φ` uniform in
//!   `[−π/4, π/4]` (the angle of an isotropic Gaussian pair is uniform). Width scales that
//!   balance towards the centre; 0 is one pickup (identical channels).
//! - **Eight pan positions.** `φ` is drawn in eight equally likely bins and each mode takes its
//!   bin's centre: the bank can then sum the side signal per pan position
//!   (`S = Σ_g s_g·Σ_{m∈g} y_m`), at the mono kernel's multiply-adds per mode-sample plus a few
//!   per pan position, where a weight per mode doubles them. Free-ringing voices, most of a
//!   chord's work, sum per position on every SIMD variant; a bank rendered alone (an excited
//!   step) weights per mode on AVX-512, whose mono projection leaves multiply-add slots idle
//!   (`modal::kernel::Stereo`). Eight positions 11° of `φ` apart are finer than the image of
//!   one object needs.
//! - **Width acts at the output.** The bank computes mid `M = Σ y` and side `S = Σ s·y` from
//!   one state per mode; the engine mixes `L = M + w·S`, `R = M − w·S` with `w` ramped over
//!   [`WIDTH_RAMP_S`], so width is automatable on ringing notes without clicks.
//!
//! The pan draw is a counter-based stream keyed by the object's seed and the mode's index
//! ([`pan_group`]): it draws nothing from the object's or the hits' generators, so every other
//! draw, and the width-0 render, is the mono engine's, bit for bit.

/// Pan positions (bins of the balance angle φ).
pub const PAN_GROUPS: usize = 8;

/// The pan group of a resonator heard at the centre (side weight 0): what
/// [`super::modal::ModalBank::set_modes`] gives every slot, and the striker's modes of scraping
/// and rolling (the scraper and ball are heard through the object, not at their own place).
pub const PAN_CENTRE: u8 = PAN_GROUPS as u8;

/// Width of a new plugin instance. Why 0.5: a mode is then at most 7.6 dB louder on one side
/// (4.0 dB on average over the pan positions): an object heard as a wide source on headphones
/// while each hit stays one object (docs/model.md §10 gives the inter-channel correlation it
/// measures per material). Saved projects and scenes from before the setting keep width 0.
pub const DEFAULT_WIDTH: f64 = 0.5;

/// Length of the width ramp after a change: the output gain's ([`super::GAIN_RAMP_S`]), for
/// the same reason (a step in a ringing mode's level is a click).
pub const WIDTH_RAMP_S: f64 = super::GAIN_RAMP_S;

/// Side weight `s = tan φ` of pan group `group` (φ at the centre of its bin); 0 for
/// [`PAN_CENTRE`] and anything beyond.
pub fn side_weight(group: u8) -> f64 {
    let g = group as usize;
    if g >= PAN_GROUPS {
        return 0.0;
    }
    let quarter = std::f64::consts::FRAC_PI_4;
    let phi = -quarter + (g as f64 + 0.5) * 2.0 * quarter / PAN_GROUPS as f64;
    phi.tan()
}

/// [`side_weight`] of every pan group and the centre, indexed by group.
pub fn side_weights() -> [f64; PAN_GROUPS + 1] {
    std::array::from_fn(|g| side_weight(g as u8))
}

/// Salt of the pan stream, so it shares no state with any other generator keyed by a seed.
const PAN_SALT: u64 = 0x57E2_E0A1_D5C0_9B1D;

/// The pan group of mode `index` of the object drawn with `seed`: SplitMix64 of the
/// (seed, index) counter, top bits as a uniform bin. Pure, so it needs no storage in the object
/// and no generator state, and it never disturbs another draw.
pub fn pan_group(seed: u64, index: usize) -> u8 {
    let mut z = (seed ^ PAN_SALT).wrapping_add((index as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (((z >> 32) * PAN_GROUPS as u64) >> 32) as u8
}

/// The smoothed width: a linear ramp of [`WIDTH_RAMP_S`] to each new target, starting at its
/// first target without a ramp. Never allocates.
#[derive(Debug, Clone, Copy)]
pub(super) struct WidthRamp {
    sample_rate_hz: f64,
    now: Option<f64>,
    target: f64,
    step: f64,
    left: u64,
}

impl WidthRamp {
    pub(super) fn new(sample_rate_hz: f64) -> Self {
        Self {
            sample_rate_hz,
            now: None,
            target: 0.0,
            step: 0.0,
            left: 0,
        }
    }

    /// Sets the target width (already sanitised to 0..=1).
    pub(super) fn set_target(&mut self, width: f64) {
        match self.now {
            None => {
                self.now = Some(width);
                self.target = width;
                self.left = 0;
            }
            Some(now) if width != self.target => {
                self.target = width;
                self.left = (WIDTH_RAMP_S * self.sample_rate_hz).round().max(1.0) as u64;
                self.step = (width - now) / self.left as f64;
            }
            Some(_) => {}
        }
    }

    /// Whether the next chunk needs the side signal: the width is or becomes non-zero in it.
    pub(super) fn is_stereo(&self) -> bool {
        self.now.is_some_and(|w| w != 0.0) || self.target != 0.0
    }

    /// Mixes mid (`left`) and side (`right`) into `L = M + w·S`, `R = M − w·S` in place,
    /// advancing the ramp.
    pub(super) fn mix(&mut self, left: &mut [f32], right: &mut [f32]) {
        let Some(mut now) = self.now else { return };
        let ramp = self.left.min(left.len() as u64) as usize;
        let (lr, lc) = left.split_at_mut(ramp);
        let (rr, rc) = right.split_at_mut(ramp);
        for (l, r) in lr.iter_mut().zip(rr.iter_mut()) {
            now += self.step;
            let (m, s) = (*l, *r * now as f32);
            *l = m + s;
            *r = m - s;
        }
        self.left -= ramp as u64;
        if self.left == 0 {
            now = self.target;
        }
        let w = now as f32;
        for (l, r) in lc.iter_mut().zip(rc.iter_mut()) {
            let (m, s) = (*l, *r * w);
            *l = m + s;
            *r = m - s;
        }
        self.now = Some(now);
    }

    /// Advances the ramp over `len` samples without output (a silent chunk).
    pub(super) fn skip(&mut self, len: usize) {
        let Some(now) = self.now else { return };
        let ramp = self.left.min(len as u64);
        self.left -= ramp;
        self.now = Some(if self.left == 0 {
            self.target
        } else {
            now + self.step * ramp as f64
        });
    }
}

impl super::Lifecycle for WidthRamp {
    fn prepare(&mut self, sample_rate_hz: f64, _max_block: usize) {
        self.sample_rate_hz = sample_rate_hz;
    }

    /// The next block starts at its width without a ramp.
    fn reset(&mut self) {
        *self = Self::new(self.sample_rate_hz);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn side_weights_are_balances_symmetric_about_the_centre() {
        for g in 0..PAN_GROUPS as u8 {
            let s = side_weight(g);
            assert!(s.abs() < 1.0, "{g}: {s}");
            let mirror = side_weight(PAN_GROUPS as u8 - 1 - g);
            assert!((s + mirror).abs() < 1e-12);
        }
        assert_eq!(side_weight(PAN_CENTRE), 0.0);
    }

    #[test]
    fn pan_groups_are_uniform_and_seeded() {
        let mut count = [0usize; PAN_GROUPS];
        for i in 0..80_000 {
            count[pan_group(7, i) as usize] += 1;
        }
        for c in count {
            assert!((c as f64 - 10_000.0).abs() < 400.0, "{count:?}");
        }
        let a: Vec<u8> = (0..64).map(|i| pan_group(1, i)).collect();
        let b: Vec<u8> = (0..64).map(|i| pan_group(2, i)).collect();
        assert_ne!(a, b);
        assert_eq!(a, (0..64).map(|i| pan_group(1, i)).collect::<Vec<_>>());
    }

    #[test]
    fn width_ramp_reaches_its_target_without_steps() {
        let mut r = WidthRamp::new(48_000.0);
        r.set_target(0.0);
        assert!(!r.is_stereo());
        r.set_target(1.0);
        assert!(r.is_stereo());
        let mut l = vec![1.0f32; 1024];
        let mut s = vec![1.0f32; 1024];
        r.mix(&mut l, &mut s);
        // L = 1 + w: rises by 1/480 per sample over 480 samples, then holds at 2.
        assert!(l.windows(2).all(|p| (p[1] - p[0]).abs() < 2.5e-3));
        assert_eq!(l[1023], 2.0);
        assert_eq!(s[1023], 0.0);
    }
}
