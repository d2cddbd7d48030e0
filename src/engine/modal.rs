//! Modal resonator bank (docs/model.md §1–2, Traer eq. 2): each mode is a complex one-pole
//! `z[n] = p·z[n−1] + g·x[n]`, `p = exp(−d + iω)`, output `Re z`. An impulse gives exactly
//! `g·e^{−dn}·cos(ωn)`, Traer's damped cosine. Struct of arrays, fixed capacity + active count.
//!
//! # Kernels
//! - **Free ringing** (no input, the common case): the one-pole recursion is latency-bound, so
//!   it is broken with powers of the pole. From the state `z[n−1]` the next `K` outputs are
//!   `y[n+k] = Re(p^{k+1}·z[n−1]) = Re(p^{k+1})·Re z − Im(p^{k+1})·Im z`, k = 0..K−1: two
//!   multiply-adds per mode-sample, all independent. The `K` samples are the SIMD lanes, so
//!   lanes already hold per-sample sums and no horizontal reduction is needed. Then
//!   `z ← p^K·z`.
//! - **Excited** (contact impulse present): the same K-sample steps, by linearity. Within a
//!   step the output is the free ringing of the state plus the input convolved with the bank's
//!   summed impulse response `h[k] = Σ_m g_m·Re(p_m^k)`, k = 0..K−1 (one K-tap response for the
//!   whole bank, rebuilt when the modes change), and the state advances as
//!   `z ← p^K·z + g·Σ_j p^{K−1−j}·x[j]`: per mode-sample two multiply-adds for the projection
//!   and two for the input sum, no per-sample horizontal reduction and no per-sample dependency
//!   chain. The convolution costs K/2 multiply-adds per sample whatever the mode count. The
//!   state update runs in f64 with the f64 powers, so it is as exact as the per-sample
//!   recursion; only the output projection is f32, as in free ringing (the output differs from
//!   the per-sample f64 recursion by f32 rounding: ≥ 120 dB SNR, see the tests).
//!
//! Both kernels are plain Rust over fixed-size arrays that LLVM vectorises; they are compiled
//! three times (AVX-512F, AVX2+FMA, portable x86-64/other) and the variant is picked once at
//! construction with runtime feature detection, so the bundle runs on any CPU.
//!
//! # Accuracy: why there is no drift
//! The state `z` is kept in **f64** and advanced by `p^K`, which is computed directly as
//! `e^{−dK}·(cos Kω, sin Kω)` in f64, never by repeated f32 multiplication. f32 appears only in
//! the output projection coefficients `Re/Im p^{k+1}` (computed the same way, then rounded),
//! whose rounding error (≤ 2^−24 relative per sample) is not fed back into the state, so it
//! cannot accumulate. Rounding of |p^K| in f64 is ~1e−16 per K samples: an undamped mode drifts
//! by ~1e−9 dB over 10 minutes, so no explicit renormalisation is needed (the f32 design would
//! need `|z_end| = |p|^B·|z_start|` rescaling each block; the f64 state makes it redundant at a
//! cost of ~1/K of the work). Frequency error comes only from f64 rounding of `ω` (exact to
//! ~1e−13 cent). States below [`FLUSH_FLOOR`] are zeroed at block ends so no denormal ever
//! reaches the f32 projection.
//!
//! # Glides
//! [`ModalBank::set_modes`] and [`ModalBank::set_mode`] keep the state of every slot, so changing
//! frequency or decay between blocks keeps amplitude and phase continuous (no click). The gain
//! is an *input* gain: it scales new excitation only; a ringing mode keeps its level when the
//! gain changes.

#[cfg(target_arch = "x86_64")]
use std::arch::asm;

/// Highest mode frequency kept, as a fraction of the sample rate.
pub const MAX_FREQ_FRACTION: f64 = 0.49;

/// Samples per free-ringing step: the number of pole powers precomputed per mode.
/// Why 32: the coefficient vectors (2·32 f32 = 8 AVX2 registers or 4 AVX-512 registers) are
/// loaded once per mode per step alongside two broadcasts of the state, so a larger K means
/// fewer loads per multiply-add (32 gives ~1.25 loads per FMA) while still fitting registers.
pub const K: usize = 32;

/// Padding granularity of the per-mode state arrays (modes). Why 32: whole AVX-512 / AVX2
/// vectors of f64 for the per-mode loops.
const LANES: usize = 32;

/// Modes per column group of the transposed pole powers (`W` f64 lanes: two AVX-512 or four
/// AVX2 registers), so that per-mode sums over a step are plain vertical multiply-adds.
const W: usize = 16;

/// |z|² below which a mode's state is zeroed at a block end (≈ −300 dB re 1 N·s·gain).
/// Why: keeps the f32 projection out of denormals, far below anything audible.
pub const FLUSH_FLOOR: f64 = 1e-30;

/// Largest accepted contact impulse per sample, in N·s. Why: physical contacts give ~1e−3 N·s
/// per sample; the bound keeps garbage input (e.g. 1e38) from overflowing the state.
pub const MAX_IMPULSE_N_S: f64 = 1e3;

/// One mode's target parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeParams {
    /// Frequency in Hz.
    pub freq_hz: f64,
    /// Amplitude decay in dB/s (≥ 0).
    pub decay_db_per_s: f64,
    /// Linear input gain (output units per N·s of impulse).
    pub gain: f64,
}

impl ModeParams {
    /// The discrete-time pole as `(d, ω)`: decay in nepers per sample and angular frequency in
    /// radians per sample, or `None` if the mode is dropped (non-finite, frequency ≤ 0 or
    /// ≥ `MAX_FREQ_FRACTION·fs`). Negative decays are clamped to 0 (an unstable mode is never
    /// intended). Shared with [`super::reference`] so both use the same model.
    pub fn pole(&self, sample_rate: f64) -> Option<(f64, f64)> {
        let nyq = MAX_FREQ_FRACTION * sample_rate;
        if !(self.freq_hz > 0.0 && self.freq_hz < nyq)
            || !self.gain.is_finite()
            || !self.decay_db_per_s.is_finite()
            || !(sample_rate > 0.0)
        {
            return None;
        }
        let w = std::f64::consts::TAU * self.freq_hz / sample_rate;
        // dB/s of amplitude → nepers per sample: ln(10)/20 nepers per dB.
        let d = self.decay_db_per_s.max(0.0) * std::f64::consts::LN_10 / 20.0 / sample_rate;
        Some((d, w))
    }
}

/// Which compiled variant of the kernels runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// Portable code (baseline target features only).
    Portable,
    /// x86-64 AVX2 + FMA.
    Avx2,
    /// x86-64 AVX-512F.
    Avx512,
}

impl Kernel {
    /// The fastest variant this CPU supports.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("fma")
            {
                return Kernel::Avx512;
            }
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                return Kernel::Avx2;
            }
        }
        Kernel::Portable
    }

    /// Whether this CPU can run the variant.
    pub fn is_supported(self) -> bool {
        match self {
            Kernel::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma"),
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512 => {
                std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx2")
                    && std::is_x86_feature_detected!("fma")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }
}

/// A bank of modes with fixed capacity.
#[derive(Debug, Clone)]
pub struct ModalBank {
    sample_rate: f64,
    active: usize,
    kernel: Kernel,
    params: Vec<ModeParams>,
    /// Powers `p^{k+1}`, k = 0..K−1, in f64 (state advance, input sums), transposed in groups
    /// of `W` modes: `tpr[m / W][k][m % W]`.
    tpr: Vec<[[f64; W]; K]>,
    tpi: Vec<[[f64; W]; K]>,
    /// The same powers rounded to f32: output projection coefficients.
    cr: Vec<[f32; K]>,
    ci: Vec<[f32; K]>,
    gain: Vec<f64>,
    /// Per mode: the threshold of hearing at its frequency as a power relative to 0 dB SPL
    /// ([`hearing_threshold_power`]), for [`ModalBank::retire_masked`].
    thr2: Vec<f64>,
    /// Per mode: its place on the masking grid (from its Bark, [`bark`], and decay), for
    /// [`ModalBank::retire_masked`] and [`ModalBank::collect_maskers`].
    mask: Vec<MaskShape>,
    /// State (f64, see module docs).
    zr: Vec<f64>,
    zi: Vec<f64>,
    /// Summed impulse response `h[k] = Σ g·Re(p^k)`, k = 0..K−1 (excited kernel), stored at
    /// `K + k` after K zeros so the step convolution runs over whole arrays.
    resp: [f64; 2 * K],
    /// `resp` must be rebuilt (the modes changed).
    resp_dirty: bool,
}

/// The threshold of hearing in quiet at `freq_hz`, dB SPL: Terhardt's (1979) approximation of
/// the ISO 226 curve, `3.64·f^−0.8 − 6.5·e^{−0.6(f−3.3)²} + 10^−3·f^4` (f in kHz), capped at
/// 40 dB SPL (Terhardt's f⁴ term overshoots above 14 kHz; young listeners hear 16 kHz at
/// about 40 dB SPL, so the cap keeps culling conservative there). Frequencies below 20 Hz
/// use the 20 Hz value.
pub fn hearing_threshold_db_spl(freq_hz: f64) -> f64 {
    let f = (freq_hz.max(20.0)) / 1000.0;
    let t = 3.64 * f.powf(-0.8) - 6.5 * (-0.6 * (f - 3.3) * (f - 3.3)).exp() + 1e-3 * f.powi(4);
    if t.is_finite() {
        t.min(40.0)
    } else {
        40.0
    }
}

/// [`hearing_threshold_db_spl`] as a power ratio to 0 dB SPL.
pub fn hearing_threshold_power(freq_hz: f64) -> f64 {
    10f64.powf(hearing_threshold_db_spl(freq_hz) / 10.0)
}

/// Critical-band rate in Bark at `freq_hz` (Traunmüller 1990: `26.81·f/(1960 + f) − 0.53`).
pub fn bark(freq_hz: f64) -> f64 {
    26.81 * freq_hz / (1960.0 + freq_hz) - 0.53
}

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

impl ModalBank {
    /// Allocates room for `capacity` modes.
    pub fn with_capacity(capacity: usize) -> Self {
        // Padded to whole lane groups; padding slots have p = 0, g = 0, z = 0.
        let padded = capacity.div_ceil(LANES) * LANES;
        Self {
            sample_rate: 48_000.0,
            active: 0,
            kernel: Kernel::detect(),
            params: vec![
                ModeParams {
                    freq_hz: 0.0,
                    decay_db_per_s: 0.0,
                    gain: 0.0
                };
                capacity
            ],
            tpr: vec![[[0.0; W]; K]; padded / W],
            tpi: vec![[[0.0; W]; K]; padded / W],
            cr: vec![[0.0; K]; padded],
            ci: vec![[0.0; K]; padded],
            gain: vec![0.0; padded],
            thr2: vec![0.0; padded],
            mask: vec![MaskShape::default(); padded],
            zr: vec![0.0; padded],
            zi: vec![0.0; padded],
            resp: [0.0; 2 * K],
            resp_dirty: true,
        }
    }

    /// Capacity in modes.
    pub fn capacity(&self) -> usize {
        self.params.len()
    }

    /// Modes currently computed.
    pub fn active(&self) -> usize {
        self.active
    }

    /// The kernel variant in use.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Forces a kernel variant (for benchmarks and tests); ignored if the CPU lacks it.
    /// Returns the variant in use.
    pub fn set_kernel(&mut self, kernel: Kernel) -> Kernel {
        if kernel.is_supported() {
            self.kernel = kernel;
        }
        self.kernel
    }

    /// Sets the sample rate and recomputes the coefficients of the current modes (modes that
    /// fall at or above `MAX_FREQ_FRACTION·fs` at the new rate are dropped).
    /// May be called off the audio thread only when not processing; never allocates.
    pub fn set_sample_rate(&mut self, sample_rate: f64) {
        if !(sample_rate > 0.0) || !sample_rate.is_finite() {
            return;
        }
        self.sample_rate = sample_rate;
        let mut n = 0;
        for i in 0..self.active {
            let m = self.params[i];
            if self.write_slot(n, &m) {
                self.zr[n] = self.zr[i];
                self.zi[n] = self.zi[i];
                n += 1;
            }
        }
        self.clear_from(n);
    }

    /// The parameters of active mode `index`.
    pub fn mode(&self, index: usize) -> Option<ModeParams> {
        (index < self.active).then(|| self.params[index])
    }

    /// Computes slot `i`'s coefficients; false (slot untouched) if the mode is dropped.
    fn write_slot(&mut self, i: usize, m: &ModeParams) -> bool {
        let Some((d, w)) = m.pole(self.sample_rate) else {
            return false;
        };
        self.params[i] = *m;
        // p^1 from exp/cos/sin; p^2 … p^K by f64 complex multiplication: each product adds at
        // most a few ulp (2^−52), so p^K is within ~K·2^−50 ≈ 3·10^−14 relative of the directly
        // computed power (below f32 resolution by 7 orders; the state update re-derives the
        // state from these powers every K samples, so this is a fixed error, not a drift). One
        // exp and one sin_cos per mode instead of K of each: the per-hit set-up cost.
        let r = (-d).exp();
        let (s1, c1) = w.sin_cos();
        let (pr, pi) = (r * c1, r * s1);
        let (mut ar, mut ai) = (pr, pi);
        for k in 0..K {
            if k > 0 {
                (ar, ai) = (ar * pr - ai * pi, ar * pi + ai * pr);
            }
            self.tpr[i / W][k][i % W] = ar;
            self.tpi[i / W][k][i % W] = ai;
            self.cr[i][k] = ar as f32;
            self.ci[i][k] = ai as f32;
        }
        self.gain[i] = m.gain;
        self.thr2[i] = hearing_threshold_power(m.freq_hz);
        self.mask[i] = MaskShape::new(bark(m.freq_hz), m.decay_db_per_s);
        self.resp_dirty = true;
        true
    }

    /// Rebuilds the summed impulse response of the active modes (never allocates).
    fn update_resp(&mut self) {
        let mut h = [0.0f64; 2 * K];
        for m in 0..self.active {
            let g = self.gain[m];
            h[K] += g;
            for k in 1..K {
                h[K + k] += g * self.tpr[m / W][k - 1][m % W];
            }
        }
        self.resp = h;
        self.resp_dirty = false;
    }

    /// Zeroes coefficients and state of slots `n..` and makes `n` the active count.
    fn clear_from(&mut self, n: usize) {
        let end = self.active.max(n).div_ceil(LANES) * LANES;
        for i in n..end {
            for k in 0..K {
                self.tpr[i / W][k][i % W] = 0.0;
                self.tpi[i / W][k][i % W] = 0.0;
            }
            self.cr[i] = [0.0; K];
            self.ci[i] = [0.0; K];
            self.gain[i] = 0.0;
            self.thr2[i] = 0.0;
            self.mask[i] = MaskShape::default();
            self.zr[i] = 0.0;
            self.zi[i] = 0.0;
        }
        self.active = n;
        self.resp_dirty = true;
    }

    /// Sets the modes; keeps the state of each slot (slot i keeps ringing with the new
    /// parameters of the i-th kept mode: glides are phase- and amplitude-continuous).
    /// Modes at or above `MAX_FREQ_FRACTION·fs`, non-finite ones and those beyond capacity are
    /// dropped (later modes move up a slot). Never allocates.
    pub fn set_modes(&mut self, modes: &[ModeParams]) {
        let mut n = 0;
        for m in modes {
            if n == self.capacity() {
                break;
            }
            if self.write_slot(n, m) {
                n += 1;
            }
        }
        self.clear_from(n);
    }

    /// Changes one active mode, keeping its state (a glide: no click; the gain affects new
    /// excitation only). Returns false and changes nothing if `index ≥ active` or the mode
    /// would be dropped (see [`ModeParams::pole`]). Never allocates.
    pub fn set_mode(&mut self, index: usize, mode: ModeParams) -> bool {
        index < self.active && self.write_slot(index, &mode)
    }

    /// Swap-removes modes whose state magnitude |z| is below `floor` (output units) and returns
    /// how many remain. Only meaningful between blocks without excitation: a mode with |z| below
    /// the floor then stays below it (|p| ≤ 1). Mode order (and so indices for
    /// [`ModalBank::set_mode`]) changes. Never allocates.
    pub fn retire_below(&mut self, floor: f32) -> usize {
        self.retire_masked(floor as f64, 0.0, None)
    }

    /// Like [`ModalBank::retire_below`], with a per-mode floor as well: a mode also retires when
    /// its power |z|² is below `threshold_scale` × its threshold of hearing
    /// ([`hearing_threshold_power`]); `threshold_scale` = 10^(−L/10) for a playback level where
    /// full scale (|z| = 1) is L dB SPL (0 disables the per-mode floor). And it retires when it is
    /// masked for good by `maskers` (see [`Maskers`]): below the masking threshold of the
    /// maskers that decay no faster than it, at its critical-band rate.
    /// Only meaningful between blocks without excitation. Never allocates.
    pub fn retire_masked(
        &mut self,
        floor: f64,
        threshold_scale: f64,
        mut maskers: Option<&mut Maskers>,
    ) -> usize {
        let floor2 = floor * floor;
        let mut i = 0;
        while i < self.active {
            let e = self.zr[i] * self.zr[i] + self.zi[i] * self.zi[i];
            let gone = e < floor2
                || e < self.thr2[i] * threshold_scale
                || !e.is_finite()
                || maskers
                    .as_deref_mut()
                    .is_some_and(|m| m.masks(e as f32, &self.mask[i], self.audible(i, threshold_scale)));
            if gone {
                let last = self.active - 1;
                self.params.swap(i, last);
                for k in 0..K {
                    let (a, b) = (self.tpr[i / W][k][i % W], self.tpi[i / W][k][i % W]);
                    self.tpr[i / W][k][i % W] = self.tpr[last / W][k][last % W];
                    self.tpi[i / W][k][i % W] = self.tpi[last / W][k][last % W];
                    self.tpr[last / W][k][last % W] = a;
                    self.tpi[last / W][k][last % W] = b;
                }
                self.cr.swap(i, last);
                self.ci.swap(i, last);
                self.gain.swap(i, last);
                self.thr2.swap(i, last);
                self.mask.swap(i, last);
                self.zr.swap(i, last);
                self.zi.swap(i, last);
                self.clear_from(last);
            } else {
                i += 1;
            }
        }
        self.active
    }

    /// The power below which mode `i` is inaudible for good, whatever the rest of the scene does:
    /// its threshold of hearing at the playback level, or the absolute floor
    /// [`crate::engine::MODE_FLOOR`]. (Not the relative `quality` floor: it falls with the voice's
    /// strongest mode.)
    fn audible(&self, i: usize, threshold_scale: f64) -> f32 {
        let abs = crate::engine::MODE_FLOOR as f64;
        (self.thr2[i] * threshold_scale).max(abs * abs) as f32
    }

    /// Offers every active mode to `maskers` (the loudest are kept).
    pub fn collect_maskers(&self, maskers: &mut Maskers) {
        for i in 0..self.active {
            let e = self.zr[i] * self.zr[i] + self.zi[i] * self.zi[i];
            maskers.offer(e as f32, &self.mask[i]);
        }
    }

    /// Clears the state (never allocates).
    pub fn reset(&mut self) {
        self.zr.iter_mut().for_each(|v| *v = 0.0);
        self.zi.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Adds the bank's response to `out`. `input` holds the contact impulse per sample
    /// (force·dt, N·s; non-finite values count as 0, magnitudes are clamped to
    /// [`MAX_IMPULSE_N_S`]); `None` means no excitation in this block (free ringing).
    /// If `input` is shorter than `out`, the missing samples count as 0.
    /// Never allocates, locks or panics.
    pub fn process(&mut self, input: Option<&[f32]>, out: &mut [f32]) {
        if self.active == 0 {
            return;
        }
        let kernel = self.kernel;
        if input.is_some() && self.resp_dirty {
            self.update_resp();
        }
        match input {
            Some(x) => {
                let len = out.len().min(x.len());
                let (head, tail) = out.split_at_mut(len);
                dispatch_excited(kernel, self.state(), &x[..len], head);
                if !tail.is_empty() {
                    dispatch_free(kernel, self.state(), tail);
                }
            }
            None => dispatch_free(kernel, self.state(), out),
        }
        // Flush tiny states (module docs) and sanitise: a non-finite state is cleared.
        for i in 0..self.active {
            let e = self.zr[i] * self.zr[i] + self.zi[i] * self.zi[i];
            if !(e >= FLUSH_FLOOR) || !e.is_finite() {
                self.zr[i] = 0.0;
                self.zi[i] = 0.0;
            }
        }
    }

    fn state(&mut self) -> State<'_> {
        let groups = self.active.div_ceil(LANES);
        State {
            tpr: &self.tpr[..groups * LANES / W],
            tpi: &self.tpi[..groups * LANES / W],
            cr: &self.cr[..self.active],
            ci: &self.ci[..self.active],
            gain: &self.gain[..groups * LANES],
            zr: &mut self.zr[..groups * LANES],
            zi: &mut self.zi[..groups * LANES],
            resp: &self.resp,
        }
    }

    /// Sum of squared mode magnitudes: an upper bound proxy of the output power, for sleeping.
    pub fn energy(&self) -> f32 {
        (0..self.active)
            .map(|i| self.zr[i] * self.zr[i] + self.zi[i] * self.zi[i])
            .sum::<f64>() as f32
    }

    /// Largest squared magnitude |z|² over the active modes (0 when none); no square roots, so the
    /// housekeeping scan of 64 voices × 64 modes stays cheap.
    pub fn max_energy(&self) -> f64 {
        (0..self.active)
            .map(|i| self.zr[i] * self.zr[i] + self.zi[i] * self.zi[i])
            .fold(0.0, f64::max)
    }

    /// Magnitude |z| of active mode `index`'s state (output units), or 0.
    pub fn magnitude(&self, index: usize) -> f64 {
        if index < self.active {
            self.zr[index].hypot(self.zi[index])
        } else {
            0.0
        }
    }
}

/// Borrowed kernel view. `gain, zr, zi` are padded to whole lane groups;
/// `tpr, tpi` hold the matching column groups; `cr, ci` exactly the active modes; `resp` is the
/// summed impulse response.
struct State<'a> {
    tpr: &'a [[[f64; W]; K]],
    tpi: &'a [[[f64; W]; K]],
    cr: &'a [[f32; K]],
    ci: &'a [[f32; K]],
    gain: &'a [f64],
    zr: &'a mut [f64],
    zi: &'a mut [f64],
    resp: &'a [f64; 2 * K],
}

/// `a·b + c`, fused when the variant has FMA (in the portable variant `mul_add` would call
/// a slow libm routine).
#[inline(always)]
fn madd32<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

#[inline(always)]
fn madd64<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// Adds the free ringing of the state over one full step, `o[k] += Re(p^{k+1}·z)` summed over
/// the modes (f32 projection), without advancing the state.
#[inline(always)]
fn project_step<const FMA: bool>(s: &State<'_>, o: &mut [f32; K]) {
    let n_modes = s.cr.len();
    // Two accumulator sets (even/odd modes) so consecutive modes' multiply-adds do not
    // wait on each other's latency.
    let mut a0 = [0.0f32; K];
    let mut a1 = [0.0f32; K];
    let mut m = 0;
    while m + 1 < n_modes {
        let (zr0, zi0) = (s.zr[m] as f32, -(s.zi[m] as f32));
        let (zr1, zi1) = (s.zr[m + 1] as f32, -(s.zi[m + 1] as f32));
        let (c0r, c0i) = (&s.cr[m], &s.ci[m]);
        let (c1r, c1i) = (&s.cr[m + 1], &s.ci[m + 1]);
        for k in 0..K {
            a0[k] = madd32::<FMA>(c0r[k], zr0, a0[k]);
            a1[k] = madd32::<FMA>(c1r[k], zr1, a1[k]);
            a0[k] = madd32::<FMA>(c0i[k], zi0, a0[k]);
            a1[k] = madd32::<FMA>(c1i[k], zi1, a1[k]);
        }
        m += 2;
    }
    if m < n_modes {
        let (zr0, zi0) = (s.zr[m] as f32, -(s.zi[m] as f32));
        for k in 0..K {
            a0[k] = madd32::<FMA>(s.cr[m][k], zr0, a0[k]);
            a0[k] = madd32::<FMA>(s.ci[m][k], zi0, a0[k]);
        }
    }
    for k in 0..K {
        o[k] += a0[k] + a1[k];
    }
}

/// Adds the free ringing of a partial step of `o.len()` < K samples (no state advance).
#[inline(always)]
fn project_partial<const FMA: bool>(s: &State<'_>, o: &mut [f32]) {
    let r = o.len().min(K);
    for m in 0..s.cr.len() {
        let (zr, zi) = (s.zr[m] as f32, -(s.zi[m] as f32));
        for k in 0..r {
            o[k] = madd32::<FMA>(s.cr[m][k], zr, madd32::<FMA>(s.ci[m][k], zi, o[k]));
        }
    }
}

/// `z ← p^r·z` for every mode (1 ≤ r ≤ K), in f64, vectorised across modes (padding slots
/// have p = 0 and z = 0).
#[inline(always)]
fn advance<const FMA: bool>(s: &mut State<'_>, r: usize) {
    let (zr, _) = s.zr.as_chunks_mut::<W>();
    let (zi, _) = s.zi.as_chunks_mut::<W>();
    for ((zr, zi), (tr, ti)) in zr.iter_mut().zip(zi.iter_mut()).zip(s.tpr.iter().zip(s.tpi)) {
        let (qr, qi) = (&tr[r - 1], &ti[r - 1]);
        let (ar, ai) = (*zr, *zi);
        for l in 0..W {
            zr[l] = madd64::<FMA>(qr[l], ar[l], -(qi[l] * ai[l]));
            zi[l] = madd64::<FMA>(qr[l], ai[l], qi[l] * ar[l]);
        }
    }
}

/// Free ringing over `out` (adds). Full K-sample steps use the f32 projection; a final partial
/// step of r < K samples uses the same coefficients and advances by the f64 `p^r`.
#[inline(always)]
fn free_generic<const FMA: bool>(mut s: State<'_>, out: &mut [f32]) {
    let mut chunks = out.chunks_exact_mut(K);
    for o in &mut chunks {
        let o: &mut [f32; K] = o.try_into().expect("chunk of K");
        project_step::<FMA>(&s, o);
        advance::<FMA>(&mut s, K);
    }
    let o = chunks.into_remainder();
    if !o.is_empty() {
        project_partial::<FMA>(&s, o);
        advance::<FMA>(&mut s, o.len());
    }
}

/// Excited path in steps of up to K samples (module docs): free ringing of the state, plus the
/// input convolved with the summed response, then the state advance with the input folded in.
#[inline(always)]
fn excited_generic<const FMA: bool>(mut s: State<'_>, input: &[f32], out: &mut [f32]) {
    for (o, x) in out.chunks_mut(K).zip(input.chunks(K)) {
        let r = o.len().min(x.len());
        // Sanitised input, zero-padded to K.
        let mut xb = [0.0f64; K];
        for (d, &v) in xb.iter_mut().zip(&x[..r]) {
            let v = v as f64;
            *d = if v.is_finite() {
                v.clamp(-MAX_IMPULSE_N_S, MAX_IMPULSE_N_S)
            } else {
                0.0
            };
        }
        // Free ringing of the state at the step start.
        if r == K {
            let o: &mut [f32; K] = (&mut o[..K]).try_into().expect("chunk of K");
            project_step::<FMA>(&s, o);
        } else {
            project_partial::<FMA>(&s, &mut o[..r]);
        }
        // The step's input through the summed response: y[k] += Σ_{j≤k} h[k−j]·x[j]
        // (`resp` holds h at K.., zeros before, so every j runs over all K outputs).
        let mut acc = [0.0f64; K];
        for (j, &xj) in xb[..r].iter().enumerate() {
            let h: &[f64; K] = (&s.resp[K - j..2 * K - j]).try_into().expect("K taps");
            for k in 0..K {
                acc[k] = madd64::<FMA>(h[k], xj, acc[k]);
            }
        }
        for (o, a) in o[..r].iter_mut().zip(&acc) {
            *o += *a as f32;
        }
        // Input sum per mode u = Σ_j p^{r−1−j}·x[j] = x[r−1] + Σ_k p^{k+1}·x[r−2−k]
        // (k ≤ r−2), vertical multiply-adds over the transposed powers; even and odd k in two
        // accumulator sets to halve the dependency chain.
        let x_last = xb[r - 1];
        advance::<FMA>(&mut s, r);
        let (zr, _) = s.zr.as_chunks_mut::<W>();
        let (zi, _) = s.zi.as_chunks_mut::<W>();
        let (gn, _) = s.gain.as_chunks::<W>();
        for (((zr, zi), g), (tr, ti)) in zr
            .iter_mut()
            .zip(zi.iter_mut())
            .zip(gn)
            .zip(s.tpr.iter().zip(s.tpi))
        {
            let (mut ur0, mut ui0) = ([0.0f64; W], [0.0f64; W]);
            let (mut ur1, mut ui1) = ([0.0f64; W], [0.0f64; W]);
            let mut k = 0;
            while k + 2 < r {
                let (x0, x1) = (xb[r - 2 - k], xb[r - 3 - k]);
                for l in 0..W {
                    ur0[l] = madd64::<FMA>(tr[k][l], x0, ur0[l]);
                    ui0[l] = madd64::<FMA>(ti[k][l], x0, ui0[l]);
                    ur1[l] = madd64::<FMA>(tr[k + 1][l], x1, ur1[l]);
                    ui1[l] = madd64::<FMA>(ti[k + 1][l], x1, ui1[l]);
                }
                k += 2;
            }
            if k + 1 < r {
                let x0 = xb[r - 2 - k];
                for l in 0..W {
                    ur0[l] = madd64::<FMA>(tr[k][l], x0, ur0[l]);
                    ui0[l] = madd64::<FMA>(ti[k][l], x0, ui0[l]);
                }
            }
            for l in 0..W {
                zr[l] = madd64::<FMA>(g[l], x_last + (ur0[l] + ur1[l]), zr[l]);
                zi[l] = madd64::<FMA>(g[l], ui0[l] + ui1[l], zi[l]);
            }
        }
    }
}

fn free_portable(s: State<'_>, out: &mut [f32]) {
    free_generic::<false>(s, out)
}

fn excited_portable(s: State<'_>, input: &[f32], out: &mut [f32]) {
    excited_generic::<false>(s, input, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn free_avx2(s: State<'_>, out: &mut [f32]) {
    free_generic::<true>(s, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn excited_avx2(s: State<'_>, input: &[f32], out: &mut [f32]) {
    excited_generic::<true>(s, input, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn free_avx512(s: State<'_>, out: &mut [f32]) {
    free_generic::<true>(s, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn excited_avx512(s: State<'_>, input: &[f32], out: &mut [f32]) {
    excited_generic::<true>(s, input, out)
}

fn dispatch_free(kernel: Kernel, s: State<'_>, out: &mut [f32]) {
    match kernel {
        // SAFETY: `kernel` is only ever a variant whose features were detected at runtime
        // (`Kernel::detect` / `ModalBank::set_kernel` check `is_supported`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { free_avx512(s, out) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { free_avx2(s, out) },
        _ => free_portable(s, out),
    }
}

/// True when every element of `a` and `b` is +0.0 (bit pattern 0; −0.0 and NaN count as
/// non-zero). Why: an idle block's outputs usually hold the zeros written one block earlier, or
/// the wrapper cleared them already (nice-plug zero-fills an instrument's output channels before
/// `process`); reading 2 × 64 samples costs less than storing them, so the idle path checks
/// first and writes only over dirty buffers.
pub fn all_zero_pair(kernel: Kernel, a: &[f32], b: &[f32]) -> bool {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    match kernel {
        // SAFETY: AVX-512F was detected at runtime for this kernel (see `dispatch_free`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { all_zero_avx512(a, b) },
        _ => a.iter().chain(b).all(|v| v.to_bits() == 0),
    }
}

/// [`all_zero_pair`] with unaligned 64-byte loads OR-ed together, the remainder scalar.
///
/// # Safety
/// AVX-512F must be available; `a` and `b` must have the same length.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn all_zero_avx512(a: &[f32], b: &[f32]) -> bool {
    use std::arch::x86_64::*;
    debug_assert_eq!(a.len(), b.len());
    let full = a.len() / 16;
    let mut acc = _mm512_setzero_si512();
    for i in 0..full {
        // SAFETY: lanes 16·i..16·i + 16 ≤ a.len() = b.len() are inside both slices; the loads
        // are unaligned (`loadu`).
        unsafe {
            acc = _mm512_or_si512(acc, _mm512_loadu_si512(a.as_ptr().add(16 * i).cast()));
            acc = _mm512_or_si512(acc, _mm512_loadu_si512(b.as_ptr().add(16 * i).cast()));
        }
    }
    _mm512_test_epi32_mask(acc, acc) == 0
        && a[16 * full..]
            .iter()
            .chain(&b[16 * full..])
            .all(|v| v.to_bits() == 0)
}

/// Makes both buffers zero: with AVX-512, reads them first and stores only if one is dirty
/// ([`all_zero_pair`]: a clean idle block costs loads, not stores); otherwise [`zero_pair`]
/// elsewhere (a baseline-SSE2 check measured slower than the stores, 9.8–13.5 vs 5.0–7.4 ns per
/// pair of 64-sample blocks; an AVX2 check was not measured).
pub fn clear_pair(kernel: Kernel, a: &mut [f32], b: &mut [f32]) {
    if kernel != Kernel::Avx512 || !all_zero_pair(kernel, a, b) {
        zero_pair(kernel, a, b);
    }
}

/// Zeroes two buffers (an idle block's outputs) with the widest stores `kernel` allows. Why not
/// `fill`: LLVM turns any zeroing loop (intrinsic stores included) into two `memset` calls, which
/// cost more than the idle engine's whole bookkeeping at small blocks; the stores are therefore
/// written in `asm!`, which the optimiser leaves alone. Both SIMD variants store whole aligned
/// cache lines / vectors wherever they can: a store split across two cache lines costs about
/// two, and host buffers are often only 16-byte aligned (measured: 512-sample blocks at a
/// 16-byte offset took twice as long with unaligned 64-byte stores).
pub fn zero_pair(kernel: Kernel, a: &mut [f32], b: &mut [f32]) {
    let n = a.len().min(b.len());
    let (a, b) = (&mut a[..n], &mut b[..n]);
    match kernel {
        // SAFETY: the features as in `dispatch_free` (AVX2 implies AVX); `a` and `b` both have
        // `n` elements, n ≥ 8 for `zero_avx`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { zero_lines_avx512(a, b) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 if n >= 8 => unsafe { zero_avx(a, b) },
        _ => {
            a.fill(0.0);
            b.fill(0.0);
        }
    }
}

/// `kmovw` masks for [`zero_lines_avx512`], indexed by a *byte* offset within a cache line
/// (a multiple of 4 for `f32` data, hence `u32` entries; `kmovw` reads the low 16 bits).
/// `head[o/4]`: lanes `o/4..16` (the slice starts `o` bytes into its first line).
/// `tail[o/4]`: lanes `0..o/4` (the slice ends `o` bytes into its last line; 0 = a full line).
#[cfg(target_arch = "x86_64")]
#[repr(C, align(64))]
struct LineMasks {
    head: [u32; 16],
    tail: [u32; 16],
}

#[cfg(target_arch = "x86_64")]
static LINE_MASKS: LineMasks = {
    let mut head = [0; 16];
    let mut tail = [0; 16];
    let mut i = 0;
    while i < 16 {
        head[i] = (0xFFFF << i) & 0xFFFF;
        tail[i] = if i == 0 { 0xFFFF } else { (1 << i) - 1 };
        i += 1;
    }
    LineMasks { head, tail }
};

/// AVX-512 zeroing with exactly one 64-byte store per cache line each slice touches: a masked
/// store to the line holding the first element (lanes from the slice start on), aligned full
/// stores to the lines in between, a masked store to the line holding the last element (lanes
/// up to the slice end); a slice within one line gets one store with both masks. No store
/// crosses a line, whatever the slices' alignment (they may differ).
///
/// # Safety
/// AVX-512F must be available; `b` must be at least as long as `a` (only `a.len()` elements of
/// each are written).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn zero_lines_avx512(a: &mut [f32], b: &mut [f32]) {
    let bytes = 4 * a.len();
    if bytes == 0 {
        return;
    }
    debug_assert!(b.len() >= a.len());
    for p in [a.as_mut_ptr(), b.as_mut_ptr()] {
        // SAFETY: `p` starts a live, exclusively borrowed `[f32]` of at least `bytes` > 0 bytes
        // (this function's contract), so `p` and `p + bytes` are 4-byte aligned; below, "the
        // slice" is its first `bytes` bytes, the only ones written. Let `first` = p & !63 and
        // `last` = (p + bytes − 1) & !63 be the lines holding its first and last byte. Stores:
        // - `vmovaps [q]` for first < q < last: q ≥ first + 64 > p and q + 64 ≤ last < p + bytes,
        //   so the whole line is inside the slice (and 64-byte aligned, as vmovaps requires);
        // - `vmovups [first]{head}`, head = lanes from (p − first)/4 on: with last > first these
        //   are the bytes [p, first + 64) ⊂ [p, last) of the slice;
        // - `vmovups [last]{tail}`, tail = lanes below (p + bytes − last)/4 (all 16 when the
        //   slice ends on a line boundary): the bytes [last, p + bytes), inside the slice since
        //   last > first implies last > p;
        // - first = last: one store, mask head ∧ tail = the bytes [p, p + bytes).
        // Masked-off lanes of an AVX-512 masked store are neither written nor checked for
        // faults (AVX-512 memory fault suppression), so no byte outside the slice is touched,
        // not even rewritten with its own value; besides, a 64-byte line never straddles a page
        // and each stored line holds bytes of the slice. The mask loads read `LINE_MASKS`
        // (32 `u32`s; offsets 0..=60 and 64..=124). AVX-512F is enabled for this function; the
        // asm clobbers only the declared registers and flags, and uses no stack.
        unsafe {
            asm!(
                "vpxord {z}, {z}, {z}",
                "lea {last}, [{p} + {bytes}]",
                "mov {t}, {p}",
                "and {t}, 63",
                "kmovw {head}, word ptr [{masks} + {t}]",
                "sub {p}, {t}",
                "mov {t}, {last}",
                "and {t}, 63",
                "kmovw {tail}, word ptr [{masks} + {t} + 64]",
                "dec {last}",
                "and {last}, -64",
                "cmp {p}, {last}",
                "jne 2f",
                "kandw {head}, {head}, {tail}",
                "vmovups zmmword ptr [{p}] {{{head}}}, {z}",
                "jmp 4f",
                "2:",
                "vmovups zmmword ptr [{p}] {{{head}}}, {z}",
                "vmovups zmmword ptr [{last}] {{{tail}}}, {z}",
                "add {p}, 64",
                "cmp {p}, {last}",
                "jae 4f",
                "3:",
                "vmovaps zmmword ptr [{p}], {z}",
                "add {p}, 64",
                "cmp {p}, {last}",
                "jb 3b",
                "4:",
                p = inout(reg) p => _,
                bytes = in(reg) bytes,
                masks = in(reg) &LINE_MASKS,
                last = out(reg) _,
                t = out(reg) _,
                head = out(kreg) _,
                tail = out(kreg) _,
                z = out(zmm_reg) _,
                options(nostack),
            );
        }
    }
    // SAFETY: clears the upper vector state the stores dirtied (no live vector values cross
    // it); without it the SSE code after the return pays transition stalls.
    unsafe { asm!("vzeroupper", options(nostack, preserves_flags)) };
}

/// AVX zeroing for slices of at least 8 elements: an unaligned 32-byte store at each end and
/// 32-byte aligned stores in between (overlapping the ends), so at most the two end stores can
/// split a cache line. (AVX has masked stores, `vmaskmovps`, but they are slow on several
/// AVX2-only CPUs.)
///
/// # Safety
/// AVX must be available; `a.len()` ≥ 8 and `b` at least as long as `a` (only `a.len()`
/// elements of each are written).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn zero_avx(a: &mut [f32], b: &mut [f32]) {
    let bytes = 4 * a.len();
    debug_assert!(bytes >= 32 && b.len() >= a.len());
    for p in [a.as_mut_ptr(), b.as_mut_ptr()] {
        // SAFETY: `p` starts a live, exclusively borrowed `[f32]` of at least `bytes` ≥ 32 bytes
        // (this function's contract); only its first `bytes` are written. Let e =
        // p + bytes − 32. The stores cover [p, p + 32), [e, e + 32) and [q, q + 32) for the
        // 32-byte aligned q with (p + 32) & !31 ≤ q < e: all inside the slice (q > p, q + 32 ≤
        // e + 32 = its end), and together all of it, since (p + 32) & !31 ≤ p + 32 and the loop
        // runs until q ≥ e. AVX is enabled for this function; the asm clobbers only the
        // declared registers and flags, and uses no stack.
        unsafe {
            asm!(
                "vxorps {z}, {z}, {z}",
                "lea {e}, [{p} + {bytes} - 32]",
                "vmovups ymmword ptr [{p}], {z}",
                "vmovups ymmword ptr [{e}], {z}",
                "add {p}, 32",
                "and {p}, -32",
                "cmp {p}, {e}",
                "jae 3f",
                "2:",
                "vmovaps ymmword ptr [{p}], {z}",
                "add {p}, 32",
                "cmp {p}, {e}",
                "jb 2b",
                "3:",
                p = inout(reg) p => _,
                bytes = in(reg) bytes,
                e = out(reg) _,
                z = out(ymm_reg) _,
                options(nostack),
            );
        }
    }
    // SAFETY: as in `zero_lines_avx512`.
    unsafe { asm!("vzeroupper", options(nostack, preserves_flags)) };
}

fn dispatch_excited(kernel: Kernel, s: State<'_>, input: &[f32], out: &mut [f32]) {
    match kernel {
        // SAFETY: as in `dispatch_free`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { excited_avx512(s, input, out) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { excited_avx2(s, input, out) },
        _ => excited_portable(s, input, out),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(freq_hz: f64, decay_db_per_s: f64, gain: f64) -> ModeParams {
        ModeParams {
            freq_hz,
            decay_db_per_s,
            gain,
        }
    }

    fn kernels() -> Vec<Kernel> {
        [Kernel::Portable, Kernel::Avx2, Kernel::Avx512]
            .into_iter()
            .filter(|k| k.is_supported())
            .collect()
    }

    /// Impulse response vs the closed form g·e^{−dn}·cos(ωn), every kernel, with a
    /// partial final step (len not a multiple of K).
    #[test]
    fn impulse_matches_damped_cosine() {
        let fs = 48_000.0;
        let modes = [
            mode(440.0, 3.0, 0.7),
            mode(3_137.5, 20.0, -0.3),
            mode(17_000.0, 60.0, 0.1),
        ];
        for kernel in kernels() {
            let mut bank = ModalBank::with_capacity(8);
            bank.set_kernel(kernel);
            bank.set_sample_rate(fs);
            bank.set_modes(&modes);
            let mut out = vec![0.0f32; 1000];
            let mut x = vec![0.0f32; 1];
            x[0] = 1.0;
            bank.process(Some(&x), &mut out[..1]);
            bank.process(None, &mut out[1..]);
            let mut max_err = 0.0f64;
            for (n, &y) in out.iter().enumerate() {
                let mut r = 0.0;
                for m in &modes {
                    let (d, w) = m.pole(fs).unwrap();
                    r += m.gain * (-d * n as f64).exp() * (w * n as f64).cos();
                }
                max_err = max_err.max((y as f64 - r).abs());
            }
            assert!(max_err < 1e-6, "{kernel:?}: max error {max_err}");
        }
    }

    #[test]
    fn kernels_agree() {
        let kk = kernels();
        let modes: Vec<_> = (0..37)
            .map(|i| mode(100.0 + 311.0 * i as f64, 2.0 + i as f64, 1.0 / (1.0 + i as f64)))
            .collect();
        let x: Vec<f32> = (0..300).map(|n| if n % 97 == 3 { 0.01 } else { 0.0 }).collect();
        let render = |k: Kernel| {
            let mut bank = ModalBank::with_capacity(64);
            bank.set_kernel(k);
            bank.set_modes(&modes);
            let mut out = vec![0.0f32; 2000];
            bank.process(Some(&x), &mut out[..300]);
            bank.process(None, &mut out[300..]);
            out
        };
        let a = render(kk[0]);
        for &k in &kk[1..] {
            let b = render(k);
            let err = a.iter().zip(&b).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
            assert!(err < 1e-6, "{k:?} differs by {err}");
        }
    }

    /// The block-wise excited kernel against the per-sample f64 recursion `z = p·z + g·x`,
    /// `y = Re z` (the previous implementation), on noise-like input over blocks of odd sizes
    /// (partial steps), with a glide and a retirement in between (the summed response must
    /// follow the mode set): ≥ 120 dB SNR for every kernel.
    #[test]
    fn excited_matches_per_sample_recursion() {
        let fs = 48_000.0;
        let mut modes: Vec<_> = (0..68)
            .map(|i| {
                mode(
                    90.0 * (1.0 + i as f64).powf(1.2),
                    3.0 + 2.0 * i as f64,
                    1.0 / (1.0 + i as f64),
                )
            })
            .collect();
        let mut seed = 12345u64;
        let x: Vec<f32> = (0..20_000)
            .map(|_| {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 1e-3
            })
            .collect();
        for kernel in kernels() {
            let mut bank = ModalBank::with_capacity(68);
            bank.set_kernel(kernel);
            bank.set_sample_rate(fs);
            bank.set_modes(&modes);
            let (mut zr, mut zi) = (vec![0.0f64; 68], vec![0.0f64; 68]);
            let (mut sig, mut err) = (0.0f64, 0.0f64);
            let mut pos = 0;
            let mut blocks = [1usize, 31, 32, 33, 64, 100, 7, 250].iter().cycle();
            let mut step = 0;
            while pos < x.len() {
                let n = (*blocks.next().unwrap()).min(x.len() - pos);
                let mut out = vec![0.0f32; n];
                bank.process(Some(&x[pos..pos + n]), &mut out);
                for (k, &y) in out.iter().enumerate() {
                    let mut r = 0.0;
                    for (m, md) in modes.iter().enumerate() {
                        let (d, w) = md.pole(fs).unwrap();
                        let (pr, pi) = ((-d).exp() * w.cos(), (-d).exp() * w.sin());
                        let nr = pr * zr[m] - pi * zi[m] + md.gain * x[pos + k] as f64;
                        zi[m] = pr * zi[m] + pi * zr[m];
                        zr[m] = nr;
                        r += nr;
                    }
                    sig += r * r;
                    err += (y as f64 - r).powi(2);
                }
                pos += n;
                step += 1;
                if step == 20 {
                    // Glide one mode and drop the last one (as `set_modes` does).
                    modes[3].freq_hz *= 1.05;
                    modes.pop();
                    bank.set_modes(&modes);
                }
            }
            let snr = 10.0 * (sig / err).log10();
            assert!(snr > 120.0, "{kernel:?}: SNR {snr} dB");
        }
    }

    #[test]
    fn set_mode_keeps_state_and_rejects_bad_params() {
        let mut bank = ModalBank::with_capacity(4);
        bank.set_modes(&[mode(1000.0, 0.0, 1.0)]);
        bank.process(Some(&[1.0]), &mut [0.0]);
        let before = bank.magnitude(0);
        assert!(bank.set_mode(0, mode(1200.0, 0.0, 5.0)));
        assert_eq!(bank.magnitude(0), before, "state kept across a glide");
        assert!(!bank.set_mode(0, mode(f64::NAN, 0.0, 1.0)));
        assert!(!bank.set_mode(0, mode(30_000.0, 0.0, 1.0)));
        assert!(!bank.set_mode(1, mode(500.0, 0.0, 1.0)));
        assert_eq!(bank.mode(0).unwrap().freq_hz, 1200.0);
    }

    #[test]
    fn retire_below_removes_quiet_modes() {
        let mut bank = ModalBank::with_capacity(8);
        // Mode 0 decays fast, mode 1 rings, mode 2 decays fast.
        bank.set_modes(&[
            mode(500.0, 2000.0, 1.0),
            mode(800.0, 0.0, 1.0),
            mode(900.0, 2000.0, 1.0),
        ]);
        let mut out = vec![0.0f32; 4800];
        bank.process(Some(&[1.0]), &mut out[..1]);
        bank.process(None, &mut out[1..]);
        assert_eq!(bank.retire_below(1e-3), 1);
        assert_eq!(bank.mode(0).unwrap().freq_hz, 800.0);
        assert!((bank.magnitude(0) - 1.0).abs() < 1e-9);
        // The survivor keeps ringing like before.
        let mut out = vec![0.0f32; 100];
        bank.process(None, &mut out);
        assert!(out.iter().any(|v| v.abs() > 0.5));
    }

    /// Hits `bank` with a unit impulse and lets it ring for `n` samples.
    fn hit_and_ring(bank: &mut ModalBank, n: usize) {
        let mut out = vec![0.0f32; n + 1];
        bank.process(Some(&[1.0]), &mut out[..1]);
        bank.process(None, &mut out[1..]);
    }

    fn masked_survivors(modes: &[ModeParams], margin_db: f64) -> Vec<f64> {
        let mut bank = ModalBank::with_capacity(8);
        bank.set_modes(modes);
        hit_and_ring(&mut bank, 480);
        let mut maskers = Maskers::new();
        maskers.begin(margin_db, 0.0);
        bank.collect_maskers(&mut maskers);
        maskers.finish();
        bank.retire_masked(0.0, 0.0, Some(&mut maskers));
        let mut f: Vec<f64> = (0..bank.active())
            .map(|i| bank.mode(i).unwrap().freq_hz)
            .collect();
        f.sort_by(f64::total_cmp);
        f
    }

    #[test]
    fn masking_retires_only_what_stays_masked() {
        // A loud 1 kHz mode (gain 1, 10 dB/s) and, 60 dB below it (gain 1e-3):
        // 1.05 kHz decaying faster (masked for good), 1.1 kHz decaying slower (would emerge: kept),
        // 8 kHz decaying faster but 12 Bark away (24 dB/Bark: not masked).
        let modes = [
            mode(1000.0, 10.0, 1.0),
            mode(1050.0, 20.0, 1e-3),
            mode(1100.0, 5.0, 1e-3),
            mode(8000.0, 20.0, 1e-3),
        ];
        assert_eq!(masked_survivors(&modes, 15.0), vec![1000.0, 1100.0, 8000.0]);
        // A margin larger than the gap masks nothing.
        assert_eq!(
            masked_survivors(&modes, 60.0),
            vec![1000.0, 1050.0, 1100.0, 8000.0]
        );
        // Below the masker, the slope is 27 dB/Bark: 900 Hz (≈0.7 Bark lower, 60 dB down) is
        // masked with a 15 dB margin, 500 Hz (≈3.4 Bark lower) is not.
        let below = [
            mode(1000.0, 10.0, 1.0),
            mode(900.0, 20.0, 1e-3),
            mode(500.0, 20.0, 1e-3),
        ];
        assert_eq!(masked_survivors(&below, 15.0), vec![500.0, 1000.0]);
    }

    #[test]
    fn all_zero_pair_sees_every_nonzero_bit() {
        let mut a = vec![0.0f32; 80];
        let mut b = vec![0.0f32; 80];
        for kernel in [Kernel::Portable, Kernel::Avx2, Kernel::Avx512] {
            if !kernel.is_supported() {
                continue;
            }
            for n in 0..=70 {
                for off in [0, 1, 3, 7] {
                    assert!(all_zero_pair(kernel, &a[off..off + n], &b[off..off + n]));
                    for i in 0..n {
                        for v in [1.0, -0.0, f32::NAN, f32::from_bits(1)] {
                            for which in 0..2 {
                                let buf = if which == 0 { &mut a } else { &mut b };
                                buf[off + i] = v;
                                assert!(
                                    !all_zero_pair(kernel, &a[off..off + n], &b[off..off + n]),
                                    "{kernel:?} n {n} off {off} [{i}] = {v} in {which}"
                                );
                                let (l, r) = (&mut a[off..off + n], &mut b[off..off + n]);
                                clear_pair(kernel, l, r);
                                assert!(l.iter().chain(r.iter()).all(|x| x.to_bits() == 0));
                            }
                        }
                    }
                    // Outside the slices nothing counts.
                    a[off + n] = 1.0;
                    assert!(all_zero_pair(kernel, &a[off..off + n], &b[off..off + n]));
                    a[off + n] = 0.0;
                }
            }
        }
    }

    #[test]
    fn zero_pair_zeroes_exactly_the_slices() {
        // 64-byte aligned storage: one line of guard elements, then slices starting at every
        // 4-byte offset within a line (`a` and `b` independently, as their alignments may
        // differ) of every length 0..=70, then guard elements up to the end. Every element
        // outside the slices must keep its value.
        #[repr(C, align(64))]
        struct Lines([f32; 16 * 7]);
        let mut a = Box::new(Lines([0.0; 16 * 7]));
        let mut b = Box::new(Lines([0.0; 16 * 7]));
        let (a, b) = (&mut a.0, &mut b.0);
        for kernel in [Kernel::Portable, Kernel::Avx2, Kernel::Avx512] {
            if !kernel.is_supported() {
                continue;
            }
            for n in 0..=70 {
                for off_a in 16..32 {
                    for off_b in 16..32 {
                        a.fill(1.0);
                        b.fill(2.0);
                        zero_pair(kernel, &mut a[off_a..off_a + n], &mut b[off_b..off_b + n]);
                        for (buf, off, guard) in [(&a, off_a, 1.0), (&b, off_b, 2.0)] {
                            for (i, &v) in buf.iter().enumerate() {
                                let want = if (off..off + n).contains(&i) { 0.0 } else { guard };
                                assert_eq!(v, want, "{kernel:?} n {n} offsets {off_a} {off_b}: [{i}]");
                            }
                        }
                    }
                }
            }
        }
    }

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

    #[test]
    fn garbage_input_stays_finite() {
        let mut bank = ModalBank::with_capacity(4);
        bank.set_modes(&[mode(0.4899 * 48_000.0, 0.0, 1e6)]);
        let x = [f32::NAN, f32::INFINITY, f32::MAX, -f32::MAX, 1.0];
        let mut out = [0.0f32; 5];
        bank.process(Some(&x), &mut out);
        let mut more = vec![0.0f32; 1000];
        bank.process(None, &mut more);
        assert!(out.iter().chain(&more).all(|v| v.is_finite()));
    }
}
