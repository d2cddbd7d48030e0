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
//!
//! Files: this one holds the bank (slots, coefficients, culling scans); `kernel.rs` the
//! per-block kernels and their SIMD variants; `masking.rs` the scene's masking threshold.

mod kernel;
mod masking;
#[cfg(test)]
mod tests;

pub use crate::engine::dsp::scales::{bark, hearing_threshold_db_spl, hearing_threshold_power};
pub use crate::engine::dsp::simd::Kernel;
pub use crate::engine::dsp::zero::{all_zero_pair, clear_pair, zero_pair};
pub use masking::{
    MaskShape, Maskers, MASK_BANDS, MASK_BAND_BARK, MASK_DECAY_CLASSES, MASK_DECAY_MIN_DB_PER_S,
    MASK_DECAY_RATIO, MASK_SLOPE_LOWER_DB_PER_BARK, MASK_SLOPE_UPPER_DB_PER_BARK,
};

use crate::engine::dsp::DB_PER_NEPER;
use crate::engine::stereo::{side_weights, PAN_CENTRE, PAN_GROUPS};
use crate::preset::ModeRing;
use kernel::{render, Groups, Mono, Runs, Side, State, Stereo};

pub use crate::engine::limits::{MAX_FREQ_FRACTION, MAX_IMPULSE_N_S};

/// Most banks [`ModalBank::process_stereo_free_batch`] renders in one pass.
pub const STEREO_BATCH: usize = kernel::BATCH;

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
        let d = self.decay_db_per_s.max(0.0) / DB_PER_NEPER / sample_rate;
        Some((d, w))
    }
}

/// The amplitude decay in dB/s of `e^{−t/τ}` (τ = `rise_s`): `20·log10(e)/τ`.
fn rise_decay_db_per_s(rise_s: f64) -> f64 {
    DB_PER_NEPER / rise_s
}

/// The resonators of a mode that builds up (docs/model.md "Build-up"): `mode` itself, and for a
/// build-up time `rise_s` > 0 (s) a partner at the same frequency with gain `−gain` and decay
/// `decay + 20·log10(e)/τ` dB/s. Their impulse responses sum to
/// `g·e^{−σt}·(1 − e^{−t/τ})·cos(ωt)` exactly (in discrete time as well: both poles share `ω`,
/// and `e^{−(d + 1/τ)n} = e^{−dn}·e^{−n/τ}`), and being two resonators of the bank's kind they
/// take the same contact force, so the contact's spectral shaping is the mode's. `None`
/// partner for `rise_s` ≤ 0 or not finite (no build-up).
pub fn build_up_pair(mode: ModeParams, rise_s: f64) -> (ModeParams, Option<ModeParams>) {
    let partner = (rise_s > 0.0 && rise_s.is_finite()).then(|| ModeParams {
        freq_hz: mode.freq_hz,
        decay_db_per_s: mode.decay_db_per_s.max(0.0) + rise_decay_db_per_s(rise_s),
        gain: -mode.gain,
    });
    (mode, partner)
}

/// The resonators of a mode that rings after its knock (docs/model.md "Ring"): `mode` with
/// its gain lowered to `(1 − s)·gain`, and for a share `s` = `ring.share` > 0 a partner at the
/// same frequency with gain `s·gain` and decay `ring.decay_ratio × decay` dB/s. Their impulse
/// responses sum to `g·((1 − s)·e^{−σt} + s·e^{−rσt})·cos(ωt)`: a mode whose energy decays in
/// two stages, as its band's does in a recording, started and shaped by the contact as one.
/// `mode` unchanged and `None` for a share ≤ 0 or above [`crate::preset::MAX_RING_SHARE`], or a
/// ratio outside (0, 1) (validation refuses those in a preset).
pub fn ring_pair(mode: ModeParams, ring: ModeRing) -> (ModeParams, Option<ModeParams>) {
    let valid = ring.share > 0.0
        && ring.share <= crate::preset::MAX_RING_SHARE
        && ring.decay_ratio > 0.0
        && ring.decay_ratio < 1.0;
    if !valid {
        return (mode, None);
    }
    (
        ModeParams {
            gain: (1.0 - ring.share) * mode.gain,
            ..mode
        },
        Some(ModeParams {
            freq_hz: mode.freq_hz,
            decay_db_per_s: mode.decay_db_per_s.max(0.0) * ring.decay_ratio,
            gain: ring.share * mode.gain,
        }),
    )
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
    /// Per slot: pan group ([`crate::engine::stereo`]; [`PAN_CENTRE`] for slots set without
    /// one) and its side weight.
    pan: Vec<u8>,
    side: Vec<f32>,
    /// The active slots grouped by pan group (the centre last), so the stereo kernel sums each
    /// pan position's modes before weighting, and the non-empty groups' ends and side
    /// coefficients in it.
    order: Vec<u16>,
    groups: Groups,
    /// Whether every active slot is at the centre (no side).
    centred: bool,
    /// `order`/`groups` must be rebuilt (slots or pans changed).
    order_dirty: bool,
    /// Side weight of each pan group ([`side_weights`]), so neither setting modes nor a block
    /// evaluates a tangent.
    weights: [f64; PAN_GROUPS + 1],
    /// Summed side impulse response `Σ s·g·Re(p^k)`, laid out as `resp`.
    resp_side: [f64; 2 * K],
    /// The projection coefficients `cr`, `ci` of the active slots copied in runs, one per pan
    /// group (the centre last), for the free-ringing stereo batch
    /// ([`ModalBank::process_stereo_free_batch`]): it reads each run front to back, so memory
    /// is read in order as by the mono kernel. `run_slot[j]` is the slot of row j,
    /// `slot_run[i]` the row of slot i, `runs[g]` group g's rows `start..end`. Rows past a
    /// run's end (left by retirement) are never read.
    run_cr: Vec<[f32; K]>,
    run_ci: Vec<[f32; K]>,
    run_slot: Vec<u16>,
    slot_run: Vec<u16>,
    runs: [(usize, usize); PAN_GROUPS + 1],
    /// The runs must be rebuilt (slots set or pans changed). Built only by the stereo batch,
    /// so a bank rendered in mono never pays for them; while built, retirement and
    /// [`ModalBank::set_mode`] keep them up to date (one row each).
    runs_dirty: bool,
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
            pan: vec![PAN_CENTRE; padded],
            side: vec![0.0; padded],
            order: vec![0; padded],
            groups: Groups::default(),
            centred: true,
            order_dirty: true,
            weights: side_weights(),
            resp_side: [0.0; 2 * K],
            run_cr: vec![[0.0; K]; padded],
            run_ci: vec![[0.0; K]; padded],
            run_slot: vec![0; padded],
            slot_run: vec![0; padded],
            runs: [(0, 0); PAN_GROUPS + 1],
            runs_dirty: true,
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
                self.set_pan(n, self.pan[i]);
                n += 1;
            }
        }
        self.clear_from(n);
        self.runs_dirty = true;
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

    /// Rebuilds the summed impulse responses (mid and side) of the active modes (never
    /// allocates).
    fn update_resp(&mut self) {
        let mut h = [0.0f64; 2 * K];
        let mut hs = [0.0f64; 2 * K];
        for m in 0..self.active {
            let g = self.gain[m];
            let gs = g * self.side[m] as f64;
            h[K] += g;
            hs[K] += gs;
            for k in 1..K {
                h[K + k] += g * self.tpr[m / W][k - 1][m % W];
                hs[K + k] += gs * self.tpr[m / W][k - 1][m % W];
            }
        }
        self.resp = h;
        self.resp_side = hs;
        self.resp_dirty = false;
    }

    /// Sets slot `i`'s pan group (anything past the last group is the centre).
    fn set_pan(&mut self, i: usize, group: u8) {
        let group = group.min(PAN_CENTRE);
        self.pan[i] = group;
        self.side[i] = self.weights[group as usize] as f32;
        self.order_dirty = true;
        self.runs_dirty = true;
        self.resp_dirty = true;
    }

    /// Rebuilds `order` (a counting sort of the active slots by pan group) and `groups`: the
    /// non-empty groups' ends and side coefficients `w_g − w_{next}` (the last's next weight is
    /// 0), see [`Stereo`]. Never allocates.
    fn update_order(&mut self) {
        let mut count = [0u16; PAN_GROUPS + 1];
        for &p in &self.pan[..self.active] {
            count[p as usize] += 1;
        }
        let mut next = [0u16; PAN_GROUPS + 1];
        let mut groups = Groups::default();
        let mut end = 0usize;
        let mut prev_w = 0.0f64;
        for g in 0..=PAN_GROUPS {
            next[g] = end as u16;
            if count[g] == 0 {
                continue;
            }
            end += count[g] as usize;
            let w = self.weights[g];
            if groups.count > 0 {
                groups.coef[groups.count - 1] = (prev_w - w) as f32;
            }
            groups.ends[groups.count] = end;
            groups.coef[groups.count] = w as f32;
            groups.count += 1;
            prev_w = w;
        }
        for i in 0..self.active {
            let g = self.pan[i] as usize;
            self.order[next[g] as usize] = i as u16;
            next[g] += 1;
        }
        self.centred = count[PAN_CENTRE as usize] as usize == self.active;
        self.groups = groups;
        self.order_dirty = false;
    }

    /// Rebuilds the runs (a counting sort of the active slots by pan group, see `run_cr`).
    /// Never allocates.
    fn update_runs(&mut self) {
        let mut count = [0usize; PAN_GROUPS + 1];
        for &p in &self.pan[..self.active] {
            count[p as usize] += 1;
        }
        let mut next = [0usize; PAN_GROUPS + 1];
        let mut end = 0;
        for g in 0..=PAN_GROUPS {
            next[g] = end;
            end += count[g];
            self.runs[g] = (next[g], end);
        }
        for i in 0..self.active {
            let j = next[self.pan[i] as usize];
            next[self.pan[i] as usize] += 1;
            self.run_cr[j] = self.cr[i];
            self.run_ci[j] = self.ci[i];
            self.run_slot[j] = i as u16;
            self.slot_run[i] = j as u16;
        }
        self.runs_dirty = false;
    }

    /// Keeps the runs up to date when slot `i` retires and slot `last` takes its place (the
    /// swap-remove of [`ModalBank::retire_masked`]): the last row of `i`'s run fills `i`'s row
    /// and the run ends one row earlier, so a retirement moves at most one row and every run
    /// stays in one piece.
    fn remove_from_runs(&mut self, i: usize, last: usize) {
        let g = self.pan[i] as usize;
        let (j, end) = (self.slot_run[i] as usize, self.runs[g].1 - 1);
        if j != end {
            self.run_cr[j] = self.run_cr[end];
            self.run_ci[j] = self.run_ci[end];
            let moved = self.run_slot[end];
            self.run_slot[j] = moved;
            self.slot_run[moved as usize] = j as u16;
        }
        self.runs[g].1 = end;
        if last != i {
            let row = self.slot_run[last];
            self.slot_run[i] = row;
            self.run_slot[row as usize] = i as u16;
        }
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
            self.pan[i] = PAN_CENTRE;
            self.side[i] = 0.0;
        }
        self.active = n;
        self.resp_dirty = true;
        self.order_dirty = true;
    }

    /// Sets the modes; keeps the state of each slot (slot i keeps ringing with the new
    /// parameters of the i-th kept mode: glides are phase- and amplitude-continuous).
    /// Modes at or above `MAX_FREQ_FRACTION·fs`, non-finite ones and those beyond capacity are
    /// dropped (later modes move up a slot). Every mode is at the centre
    /// ([`ModalBank::set_modes_panned`] for stereo). Never allocates.
    pub fn set_modes(&mut self, modes: &[ModeParams]) {
        self.set_modes_panned(modes, &[]);
    }

    /// [`ModalBank::set_modes`] with each mode's pan group (`pans[j]` for `modes[j]`, see
    /// [`crate::engine::stereo`]; missing entries are the centre). Pans only matter to
    /// [`ModalBank::process_stereo`]: [`ModalBank::process`] renders the same mono sum whatever
    /// they are. Never allocates.
    pub fn set_modes_panned(&mut self, modes: &[ModeParams], pans: &[u8]) {
        let mut n = 0;
        for (j, m) in modes.iter().enumerate() {
            if n == self.capacity() {
                break;
            }
            if self.write_slot(n, m) {
                self.set_pan(n, pans.get(j).copied().unwrap_or(PAN_CENTRE));
                n += 1;
            }
        }
        self.clear_from(n);
        self.runs_dirty = true;
    }

    /// Pan group of active mode `index` ([`PAN_CENTRE`] when out of range).
    pub fn pan(&self, index: usize) -> u8 {
        if index < self.active {
            self.pan[index]
        } else {
            PAN_CENTRE
        }
    }

    /// Changes one active mode, keeping its state (a glide: no click; the gain affects new
    /// excitation only). Returns false and changes nothing if `index ≥ active` or the mode
    /// would be dropped (see [`ModeParams::pole`]). Never allocates.
    pub fn set_mode(&mut self, index: usize, mode: ModeParams) -> bool {
        let written = index < self.active && self.write_slot(index, &mode);
        if written && !self.runs_dirty {
            let j = self.slot_run[index] as usize;
            self.run_cr[j] = self.cr[index];
            self.run_ci[j] = self.ci[index];
        }
        written
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
                if !self.runs_dirty {
                    self.remove_from_runs(i, last);
                }
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
                self.pan.swap(i, last);
                self.side.swap(i, last);
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
        if input.is_some() && self.resp_dirty {
            self.update_resp();
        }
        let kernel = self.kernel;
        let (mut s, _) = self.views();
        render(kernel, &mut s, input, Mono(out));
        self.flush();
    }

    /// Stereo form of [`ModalBank::process`]: adds the mid `Σ y_m` to `mid` and the side
    /// `Σ s_m·y_m` ([`crate::engine::stereo`], `s_m` the side weight of the mode's pan group) to
    /// `side` (equal lengths; the shorter bounds both). A bank whose modes are all at the centre
    /// adds only the mid. The mid differs from [`ModalBank::process`] by f32 rounding where the
    /// side is summed by pan group, and is [`ModalBank::process`]'s output bit for bit where it
    /// is weighted per mode (see `kernel::Stereo`). Never allocates, locks or panics.
    pub fn process_stereo(&mut self, input: Option<&[f32]>, mid: &mut [f32], side: &mut [f32]) {
        if self.active == 0 {
            return;
        }
        if self.order_dirty {
            self.update_order();
        }
        if self.centred {
            // Every mode at the centre: no side.
            return self.process(input, mid);
        }
        if input.is_some() && self.resp_dirty {
            self.update_resp();
        }
        let kernel = self.kernel;
        let (mut s, st) = self.views();
        let out = Stereo {
            side: &st,
            mid,
            os: side,
        };
        render(kernel, &mut s, input, out);
        self.flush();
    }

    /// Free ringing of several banks into one stereo mid and side (adds), as
    /// [`ModalBank::process_stereo`] with no input would give bank by bank (state flushed as
    /// well), up to f32 rounding (each bank's side summed by parts over its pan-sorted copy of
    /// its coefficients, see `kernel::render_free_stereo_batch`). `None` entries are skipped.
    /// Never allocates, locks or panics.
    pub fn process_stereo_free_batch(
        banks: &mut [Option<&mut ModalBank>],
        mid: &mut [f32],
        side: &mut [f32],
    ) {
        let mut first: Option<(Kernel, [f64; PAN_GROUPS + 1])> = None;
        for slot in banks.iter_mut() {
            let Some(b) = slot.as_deref_mut() else { continue };
            if b.active == 0 {
                *slot = None;
                continue;
            }
            if b.runs_dirty {
                b.update_runs();
            }
            let centre = b.runs[PAN_CENTRE as usize];
            let centred = centre.1 - centre.0 == b.active;
            let same = first.is_none_or(|(k, w)| k == b.kernel && w == b.weights);
            if centred || !same {
                // No side, or a bank that cannot share the batch's kernel or weights: alone.
                b.process_stereo(None, mid, side);
                *slot = None;
                continue;
            }
            first.get_or_insert((b.kernel, b.weights));
        }
        let Some((kernel, w)) = first else { return };
        let weights: [f32; PAN_GROUPS] = std::array::from_fn(|g| w[g] as f32);
        let mut it = banks.iter_mut().filter_map(|b| b.as_deref_mut());
        loop {
            let mut views: [Option<kernel::BatchView<'_>>; kernel::BATCH] = std::array::from_fn(|_| None);
            let mut n = 0;
            for (v, b) in views.iter_mut().zip(&mut it) {
                *v = Some(b.batch_view());
                n += 1;
            }
            if n == 0 {
                break;
            }
            kernel::render_free_stereo_batch(kernel, &mut views[..n], &weights, mid, side);
        }
    }

    /// Flushes tiny states (module docs) and sanitises: a non-finite state is cleared.
    fn flush(&mut self) {
        for i in 0..self.active {
            let e = self.zr[i] * self.zr[i] + self.zi[i] * self.zi[i];
            if !(e >= FLUSH_FLOOR) || !e.is_finite() {
                self.zr[i] = 0.0;
                self.zi[i] = 0.0;
            }
        }
    }

    /// Whether [`ModalBank::process_stereo`]'s full steps weight each mode by its side weight
    /// rather than summing by parts over the pan groups (see `kernel::Stereo`): on the AVX-512
    /// variant, whose mid projection leaves multiply-add slots idle. The free-ringing batch sums
    /// by parts on every variant: over its pan-sorted copy that costs less than the per-mode
    /// weights' second accumulators (`tactus bench --only "stereo vs mono"`, docs/bench).
    fn side_per_mode(&self) -> bool {
        self.kernel == Kernel::Avx512
    }

    /// The kernels' views of the active slots: the state (mutable) and the pan groups.
    fn views(&mut self) -> (State<'_>, Side<'_>) {
        let (state, side, _) = self.batch_view();
        (state, side)
    }

    /// [`ModalBank::views`] and the runs, for the stereo batch (which needs the runs up to
    /// date).
    fn batch_view(&mut self) -> kernel::BatchView<'_> {
        let n = self.active;
        let per_mode = self.side_per_mode();
        let padded = n.div_ceil(LANES) * LANES;
        let state = State {
            tpr: &self.tpr[..padded / W],
            tpi: &self.tpi[..padded / W],
            cr: &self.cr[..n],
            ci: &self.ci[..n],
            gain: &self.gain[..padded],
            zr: &mut self.zr[..padded],
            zi: &mut self.zi[..padded],
            resp: &self.resp,
        };
        let side = Side {
            order: &self.order[..n],
            groups: &self.groups,
            side: &self.side[..n],
            resp: &self.resp_side,
            per_mode,
        };
        let runs = Runs {
            cr: &self.run_cr,
            ci: &self.run_ci,
            slot: &self.run_slot,
            runs: &self.runs,
        };
        (state, side, runs)
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
