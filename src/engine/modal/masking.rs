//! The scene's masking threshold on a Bark × decay-class grid, for retiring masked modes
//! (docs/model.md §8).

/// Width of one band of the masking threshold grid, Bark.
pub const MASK_BAND_BARK: f64 = 0.25;

/// Bands of the grid: −0.5 … 25.75 Bark (the critical-band rate of 0 Hz … 24 kHz and beyond;
/// modes outside are clamped into the end bands, where the stored threshold is a lower bound).
pub const MASK_BANDS: usize = 105;

const MASK_BARK_MIN: f64 = -0.5;

/// Decay classes of the grid: class 0 holds decays below [`MASK_DECAY_MIN_DB_PER_S`], class
/// `c ≥ 1` decays in `[D·R^(c−1), D·R^c)` with `R` = [`MASK_DECAY_RATIO`], the last class
/// everything faster (≥ 0.5·1.06^126 ≈ 770 dB/s: gone in a tenth of a second, never a masker).
pub const MASK_DECAY_CLASSES: usize = 128;

/// Upper edge of decay class 0, dB/s.
pub const MASK_DECAY_MIN_DB_PER_S: f64 = 0.5;

/// Ratio between decay class edges: a mode is masked only by maskers of lower classes, i.e.
/// decaying at least 0–12 % more slowly than it does.
pub const MASK_DECAY_RATIO: f64 = 1.06;

/// Grid bands per critical band (1 Bark) sharing one masked-power budget ([`Maskers::masks`]).
const MASK_BUDGET_BANDS: usize = 4;
const MASK_BUDGETS: usize = MASK_BANDS.div_ceil(MASK_BUDGET_BANDS);

/// The threshold's factor from one band to the next, below and above the masker.
const MASK_STEP_BELOW: f32 = 0.211_348_9; // 10^(−0.25·27/10)
const MASK_STEP_ABOVE: f32 = 0.251_188_64; // 10^(−0.25·24/10)

/// Weight of same-class maskers for a mode at full scale: 10^(−(R − 1)·(0 − L_floor)/10), with
/// L_floor = 20·log10([`crate::engine::MODE_FLOOR`]) = −130 dB: 7.8 dB (see [`Maskers::masks`]).
const MASK_SAME_CLASS_GAIN: f32 = 0.165_958_7; // 10^(−0.78)

/// How far a masker's threshold is spread, Bark on either side: beyond 3 Bark it has fallen by
/// more than 72 dB, below anything the margin lets through.
const MASK_REACH_BARK: f64 = 3.0;

/// Slope of the masking threshold towards lower frequencies (maskee below the masker), dB per
/// Bark (Zwicker & Fastl; level-independent).
pub const MASK_SLOPE_LOWER_DB_PER_BARK: f64 = 27.0;

/// Slope towards higher frequencies, dB per Bark. The real upper slope flattens with level
/// (Terhardt: `24 + 0.23/f_kHz − 0.2·L`); its steepest, low-level value is used at every level,
/// which masks least, and being level-independent it keeps a masked mode masked while both
/// decay (see [`Maskers`]).
pub const MASK_SLOPE_UPPER_DB_PER_BARK: f64 = 24.0;

/// The global masking threshold of a scene: every sounding mode of every voice is a masker
/// (docs/model.md §8; Raghuvanshi & Lin 2006 cull masked modes; the masking model is the MPEG-1
/// psychoacoustic model 1 tonal masker, with power-additive thresholds as in that model).
///
/// A masker of power `P` (dB) at `z` Bark raises the threshold at `z'` by the power
/// `P − (6.025 + 0.275·z) − margin − s·|z' − z|` dB, with `s` the lower or upper slope
/// ([`MASK_SLOPE_LOWER_DB_PER_BARK`], [`MASK_SLOPE_UPPER_DB_PER_BARK`]) and `margin` a safety
/// margin set by the caller (the engine uses `(quality − 60) / 4` dB, at least 0: [`crate::engine::masking_margin_db`]); the thresholds of all maskers
/// add as powers. A mode below the threshold at its critical-band rate is masked.
///
/// Retiring is permanent, so a mode is only retired when it *stays* masked: only maskers that
/// decay no faster than the mode count towards its threshold. Each such contribution is level-independent in shape, so relative to the mode it only grows, and
/// so does their sum. The threshold is kept on a grid of [`MASK_BANDS`] bands of
/// [`MASK_BAND_BARK`] by [`MASK_DECAY_CLASSES`] decay classes, summed over the classes at or
/// below each class ([`Maskers::finish`]); a mode reads the sum over the classes whose decays are
/// all at most its own, at its band. Each band stores the threshold at the band's point farthest
/// from each masker, a lower bound of the threshold anywhere in the band. A mode never counts
/// as its own masker (its own class is never included).
///
/// What this does not cover: a masker that stops early (its voice stolen), or that is itself
/// retired as masked in the same pass; the masked mode was then already `margin` dB below the
/// threshold. Cost: one pass over every sounding mode, ≤ 25 bands each, plus a sweep of the
/// grid (13 440 cells), every [`crate::engine::MASKING_EVERY`]-th housekeeping.
/// Where a mode sits on the masking grid, precomputed when the mode is written so that a
/// masking pass costs no transcendental function per mode: its decay class, its band and the
/// bands its threshold reaches, and the threshold's gain (before the margin) in its own band
/// and in the first band either side.
#[derive(Debug, Clone, Copy, Default)]
pub struct MaskShape {
    class: u8,
    own: u8,
    lo: u8,
    hi: u8,
    own_gain: f32,
    below: f32,
    above: f32,
    /// The mode's own decay, dB/s (for the finite-horizon test of [`Maskers::masks`]).
    decay: f32,
}

impl MaskShape {
    /// The shape of a mode at `bark` decaying at `decay_db_per_s` (non-finite Bark: masks nothing).
    pub fn new(bark: f64, decay_db_per_s: f64) -> Self {
        if !bark.is_finite() {
            return Self::default();
        }
        let z = bark.clamp(MASK_BARK_MIN, MASK_BARK_MIN + MASK_BANDS as f64 * MASK_BAND_BARK);
        let own = Maskers::band(z);
        let own_lo = MASK_BARK_MIN + own as f64 * MASK_BAND_BARK;
        let peak = 10f64.powf(-(6.025 + 0.275 * z.max(0.0)) / 10.0);
        // Each band holds the threshold at its point farthest from the masker: the lower edge
        // for bands below (27 dB/Bark), the upper edge for bands above (24 dB/Bark).
        let below = peak * 10f64.powf(-(z - own_lo).max(0.0) * MASK_SLOPE_LOWER_DB_PER_BARK / 10.0);
        let above =
            peak * 10f64.powf(-(own_lo + MASK_BAND_BARK - z).max(0.0) * MASK_SLOPE_UPPER_DB_PER_BARK / 10.0);
        Self {
            class: Maskers::class(decay_db_per_s) as u8,
            own: own as u8,
            lo: Maskers::band(z - MASK_REACH_BARK) as u8,
            hi: Maskers::band(z + MASK_REACH_BARK) as u8,
            own_gain: below.min(above) as f32,
            below: below as f32,
            above: above as f32,
            decay: if decay_db_per_s.is_finite() {
                decay_db_per_s.max(0.0) as f32
            } else {
                0.0
            },
        }
    }
}

#[derive(Debug, Clone)]
pub struct Maskers {
    /// Threshold power per (decay class, band); summed over classes by `finish`.
    grid: Vec<[f32; MASK_BANDS]>,
    margin_db: f64,
    /// The largest summed threshold power: modes above it cannot be masked.
    loudest_threshold: f64,
    /// 10^(−margin/10).
    margin_gain: f32,
    /// The classes and bands written since `begin` (empty when `lo > hi`); the rest is zero.
    classes: (usize, usize),
    bands: (usize, usize),
    /// Power of the modes retired as masked, per critical band ([`MASK_BUDGET_BANDS`] grid bands,
    /// 1 Bark), as it stands now (decayed since): masked modes add as powers within a critical
    /// band, so their sum must stay under the threshold, not each one alone.
    removed: [f32; MASK_BUDGETS],
    /// The slowest decay among the modes in `removed`, per critical band, dB/s.
    removed_decay: [f32; MASK_BUDGETS],
}

impl Default for Maskers {
    fn default() -> Self {
        Self::new()
    }
}

impl Maskers {
    /// An empty grid (allocates it; reuse it with [`Maskers::begin`]).
    pub fn new() -> Self {
        Self {
            grid: vec![[0.0; MASK_BANDS]; MASK_DECAY_CLASSES],
            margin_db: 0.0,
            margin_gain: 1.0,
            loudest_threshold: 0.0,
            classes: (MASK_DECAY_CLASSES, 0),
            bands: (MASK_BANDS, 0),
            removed: [0.0; MASK_BUDGETS],
            removed_decay: [f32::INFINITY; MASK_BUDGETS],
        }
    }

    /// Forgets the masked power (on an engine reset). Never allocates.
    pub fn clear_removed(&mut self) {
        self.removed = [0.0; MASK_BUDGETS];
        self.removed_decay = [f32::INFINITY; MASK_BUDGETS];
    }

    /// Clears the grid for a new pass with a safety margin in dB (≥ 0; more margin masks less),
    /// `elapsed_s` seconds after the previous pass (the masked power decays by that much, at the
    /// slowest decay it holds). Never allocates.
    pub fn begin(&mut self, margin_db: f64, elapsed_s: f64) {
        let dt = if elapsed_s.is_finite() {
            elapsed_s.max(0.0)
        } else {
            0.0
        };
        for (p, d) in self.removed.iter_mut().zip(self.removed_decay.iter_mut()) {
            if *p > 0.0 {
                *p *= 10f32.powf(-(*d * dt as f32) / 10.0);
                if !(*p >= f32::MIN_POSITIVE) {
                    *p = 0.0;
                }
            }
            if *p == 0.0 {
                *d = f32::INFINITY;
            }
        }
        let (c0, c1) = self.classes;
        let (b0, b1) = self.bands;
        if c0 <= c1 && b0 <= b1 {
            for row in &mut self.grid[c0..=c1] {
                row[b0..=b1].fill(0.0);
            }
        }
        self.classes = (MASK_DECAY_CLASSES, 0);
        self.bands = (MASK_BANDS, 0);
        self.loudest_threshold = 0.0;
        self.margin_db = if margin_db.is_finite() {
            margin_db.max(0.0)
        } else {
            0.0
        };
        self.margin_gain = 10f64.powf(-self.margin_db / 10.0) as f32;
    }

    /// The decay class a masker of `decay_db_per_s` falls in.
    fn class(decay_db_per_s: f64) -> usize {
        if !(decay_db_per_s >= MASK_DECAY_MIN_DB_PER_S) {
            return 0;
        }
        let c = 1.0 + (decay_db_per_s / MASK_DECAY_MIN_DB_PER_S).ln() / MASK_DECAY_RATIO.ln();
        (c as usize).min(MASK_DECAY_CLASSES - 1)
    }

    fn band(bark: f64) -> usize {
        (((bark - MASK_BARK_MIN) / MASK_BAND_BARK).max(0.0) as usize).min(MASK_BANDS - 1)
    }

    /// Adds a masker of power |z|² and `shape`. Zero or non-finite powers are ignored.
    /// No transcendental function: the bands either side follow by a constant factor each.
    pub fn offer(&mut self, power: f32, shape: &MaskShape) {
        if !(power > 0.0) || !power.is_finite() {
            return;
        }
        let p = power * self.margin_gain;
        let (class, own) = (shape.class as usize, shape.own as usize);
        let (lo, hi) = (shape.lo as usize, shape.hi as usize);
        let row = &mut self.grid[class];
        row[own] += p * shape.own_gain;
        let mut below = p * shape.below;
        for cell in row[lo..own].iter_mut().rev() {
            below *= MASK_STEP_BELOW;
            *cell += below;
        }
        let mut above = p * shape.above;
        for cell in &mut row[own + 1..=hi] {
            above *= MASK_STEP_ABOVE;
            *cell += above;
        }
        self.classes = (self.classes.0.min(class), self.classes.1.max(class));
        self.bands = (self.bands.0.min(lo), self.bands.1.max(hi));
    }

    /// Sums the grid over decay classes; call after the last [`Maskers::offer`].
    pub fn finish(&mut self) {
        self.loudest_threshold = 0.0;
        let (c0, c1) = self.classes;
        let (b0, b1) = self.bands;
        if c0 > c1 || b0 > b1 {
            return;
        }
        for c in c0 + 1..=c1 {
            let (done, rest) = self.grid.split_at_mut(c);
            for (cell, p) in rest[0][b0..=b1].iter_mut().zip(&done[c - 1][b0..=b1]) {
                *cell += p;
            }
        }
        // The last class (the fastest decays) never masks: the largest usable sum is below it.
        let top = c1.min(MASK_DECAY_CLASSES - 2).max(c0);
        self.loudest_threshold = self.grid[top][b0..=b1]
            .iter()
            .fold(0.0f64, |m, &v| m.max(v as f64));
    }

    /// Whether a mode of power `power` (|z|²) and `shape` is masked for good. `audible` is the
    /// power below which the mode is inaudible anyway (its threshold of hearing, or the floor it
    /// retires at; 0 if unknown).
    ///
    /// Maskers of lower decay classes count in full. Maskers of the mode's own class decay at
    /// most [`MASK_DECAY_RATIO`] times as fast as the mode, so the gap to them closes by at most
    /// `(R − 1)·decay` dB/s while the mode falls by `decay` dB/s; by the time the mode reaches
    /// `audible` (or, if that is 0, [`crate::engine::MODE_FLOOR`], where it retires anyway) the
    /// gap has closed by at most `(R − 1)·(L − L_audible)` dB: their contribution counts with that
    /// penalty (with the floor: 7.8 dB for any mode at or below full scale).
    ///
    /// **Finite horizon.** Maskers that decay faster than the mode count too if the mode becomes
    /// inaudible before it can emerge from them: the summed threshold `T_c` of the classes up to
    /// `c` decays at most at class `c`'s upper edge `d_c`, so it stays above `audible` for
    /// `t* = 10·log10(T_c/audible)/d_c` seconds, while the gap to the mode (decaying at `d`) shrinks
    /// linearly in dB. The mode never emerges if it has reached `audible` by `t*`:
    /// `T_c ≥ audible·(P/audible)^(d_c/d)`. Checked for each class above the mode's own, up to the
    /// first where the right-hand side exceeds the loudest threshold.
    ///
    /// **Masked power adds up.** The test is made for the mode's power plus the power already
    /// retired as masked in its critical band (1 Bark: 4 grid bands) (decayed since, at the slowest of those modes' decays), with
    /// the slower of the two decays; a retired mode's power joins that sum. So many modes each
    /// under the threshold cannot together remove more than the threshold's worth.
    pub fn masks(&mut self, power: f32, shape: &MaskShape, audible: f32) -> bool {
        let band = shape.own as usize / MASK_BUDGET_BANDS;
        let (sum, decay) = (
            power + self.removed[band],
            shape.decay.min(self.removed_decay[band]),
        );
        if !((sum as f64) < self.loudest_threshold) {
            return false;
        }
        let shape_sum = if decay < shape.decay {
            MaskShape {
                class: Self::class(decay as f64) as u8,
                decay,
                ..*shape
            }
        } else {
            *shape
        };
        if self.masks_alone(sum, &shape_sum, audible) {
            self.removed[band] = sum;
            self.removed_decay[band] = decay;
            true
        } else {
            false
        }
    }

    /// [`Maskers::masks`] for one component of power `power`, ignoring what was retired before.
    /// Its caller has already checked `power < loudest_threshold`.
    fn masks_alone(&self, power: f32, shape: &MaskShape, audible: f32) -> bool {
        let band = shape.own as usize;
        let own_class = shape.class as usize;
        let (c0, c1) = self.classes;
        // Rows above c1 were never written: the sum over the classes below a mode is row
        // min(own − 1, c1); rows below c0 are zero.
        let slower = if own_class > c0 {
            self.grid[(own_class - 1).min(c1)][band]
        } else {
            0.0
        };
        if power < slower {
            return true;
        }
        if own_class == MASK_DECAY_CLASSES - 1 || own_class > c1 {
            return false;
        }
        let knows_audible = audible > 0.0 && audible.is_finite() && power > audible;
        if own_class > 0 && own_class >= c0 && power < self.grid[own_class][band] {
            let own = (self.grid[own_class][band] - slower).max(0.0);
            // The penalty grows with the mode's level above where it stops mattering.
            let penalty = if knows_audible {
                (-(MASK_DECAY_RATIO - 1.0) * (power as f64 / audible as f64).ln()).exp() as f32
            } else if power <= 1.0 {
                MASK_SAME_CLASS_GAIN
            } else {
                let floor_db = 20.0 * (crate::engine::MODE_FLOOR as f64).log10();
                let db = (MASK_DECAY_RATIO - 1.0) * (10.0 * (power as f64).log10() - floor_db);
                10f64.powf(-db / 10.0) as f32
            };
            if power < slower + own * penalty {
                return true;
            }
        }
        // Finite horizon over the faster classes (the last class never masks).
        if !knows_audible || !(shape.decay > 0.0) {
            return false;
        }
        let top = c1.min(MASK_DECAY_CLASSES - 2);
        // Cheap test first (no transcendental function): even all maskers together must lie
        // above the mode now.
        if top <= own_class || !(power < self.grid[top][band]) {
            return false;
        }
        let ln_ratio = (power as f64 / audible as f64).ln();
        let per_db_s = ln_ratio / shape.decay as f64;
        for c in (own_class + 1).max(c0)..=top {
            let d_c = MASK_DECAY_MIN_DB_PER_S * MASK_DECAY_RATIO.powi(c as i32);
            let need = audible as f64 * (per_db_s * d_c).exp();
            if need > self.loudest_threshold {
                break;
            }
            if self.grid[c][band] as f64 >= need {
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masking_thresholds_add_and_ignore_garbage() {
        // Maskers 0.5 Bark above a probe: one masks it up to its threshold, two equal ones (+3 dB)
        // mask it 2 dB above that.
        let z = 10.0;
        let probe_db = |m: &Maskers, db: f64| {
            m.clone()
                .masks(10f64.powf(db / 10.0) as f32, &MaskShape::new(z, 50.0), 0.0)
        };
        let one_db = -(6.025 + 0.275 * (z + 0.5)) - 0.5 * MASK_SLOPE_LOWER_DB_PER_BARK;
        let mut m = Maskers::new();
        m.begin(0.0, 0.0);
        m.offer(1.0, &MaskShape::new(z + 0.5, 10.0));
        m.finish();
        // The probe's band [10, 10.25) Bark holds the bound at its far edge, 0.5 Bark below.
        assert!(probe_db(&m, one_db - 0.1));
        assert!(!probe_db(&m, one_db + 0.1));
        assert!(!probe_db(&m, -6.025 - 0.275 * (z + 0.5)));
        let mut pair = Maskers::new();
        pair.begin(0.0, 0.0);
        pair.offer(1.0, &MaskShape::new(z + 0.5, 10.0));
        pair.offer(1.0, &MaskShape::new(z + 0.5, 10.0));
        pair.finish();
        assert!(probe_db(&pair, one_db + 2.0));
        assert!(!probe_db(&m, one_db + 2.0));
        // A masker decaying faster than the probe (a higher class) never counts.
        let mut fast = Maskers::new();
        fast.begin(0.0, 0.0);
        fast.offer(1.0, &MaskShape::new(z, 60.0));
        fast.finish();
        assert!(!probe_db(&fast, -100.0));
        // ... unless the probe becomes inaudible before it can emerge (finite horizon): 5 dB
        // under a masker decaying at 60 dB/s (class edge ≤ 63.6), the probe at 50 dB/s emerges
        // once the gap has closed, after the masker has fallen ≥ 5·63.6/13.6 ≈ 23 dB. A probe 10 dB
        // above its audible floor is gone by then; one 40 dB above it is not.
        let mut fast_z = Maskers::new();
        fast_z.begin(0.0, 0.0);
        fast_z.offer(1.0, &MaskShape::new(z + 0.5, 60.0));
        fast_z.finish();
        let p_db = one_db - 5.0;
        let probe_with = |audible_db: f64| {
            fast_z.clone().masks(
                10f64.powf(p_db / 10.0) as f32,
                &MaskShape::new(z, 50.0),
                10f64.powf(audible_db / 10.0) as f32,
            )
        };
        assert!(probe_with(p_db - 10.0));
        assert!(!probe_with(p_db - 40.0));
        assert!(
            !probe_with(p_db + 1.0),
            "below its floor: retired by the hearing floor, not by masking"
        );
        // One of the probe's own class counts with the penalty (R − 1)·(L − L_floor) dB:
        // 7.8 dB for any mode at or below full scale, so a probe just under the bare threshold is not
        // masked.
        let mut same = Maskers::new();
        same.begin(0.0, 0.0);
        same.offer(1.0, &MaskShape::new(z + 0.5, 50.2));
        same.finish();
        assert!(probe_db(&same, -100.0));
        assert!(!probe_db(&same, one_db - 7.7));
        assert!(probe_db(&same, one_db - 7.9));
        // Masked power adds up: two probes each 2 dB under the threshold are not both masked
        // (together they are 1 dB over it); after the first one's power has decayed by 20 dB
        // (0.4 s at 50 dB/s), the second fits.
        let mut budget = m.clone();
        let probe = |db: f64| (10f64.powf(db / 10.0) as f32, MaskShape::new(z, 50.0));
        let (p, shape) = probe(one_db - 2.0);
        assert!(budget.masks(p, &shape, 0.0));
        assert!(!budget.masks(p, &shape, 0.0));
        budget.begin(0.0, 0.4);
        budget.offer(1.0, &MaskShape::new(z + 0.5, 10.0));
        budget.finish();
        assert!(budget.masks(p, &shape, 0.0));
        budget.clear_removed();
        assert!(budget.masks(p, &shape, 0.0));
        // Non-finite or zero powers are never maskers; begin() clears the grid.
        let mut g = Maskers::new();
        g.begin(0.0, 0.0);
        g.offer(f32::NAN, &MaskShape::new(1.0, 1.0));
        g.offer(0.0, &MaskShape::new(1.0, 1.0));
        g.offer(f32::INFINITY, &MaskShape::new(1.0, 1.0));
        g.offer(1.0, &MaskShape::new(f64::NAN, 1.0));
        g.finish();
        assert!(!g.masks(1e-30, &MaskShape::new(1.0, 100.0), 0.0));
        m.begin(0.0, 0.0);
        m.finish();
        assert!(!probe_db(&m, -200.0));
    }
}
