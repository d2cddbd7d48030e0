//! Measured surfaces that never loop (docs/model.md §6 "Measured surfaces"): profiles with the
//! height spectrum and height distribution of twelve surfaces measured by Agarwal et al. 2021
//! (a confocal microscope's line scans, shipped with PyImpact), synthesised per seed without end.
//!
//! The scans themselves do not ship: [`super::measured_data`] holds per surface its RMS height,
//! its height spectrum in third-octave bands of spatial frequency and a quantile table of its
//! heights (derived from the scans by `tactus surfaces derive`, src/analysis/surfaces.rs).
//!
//! Synthesis (amplitude-adjusted Fourier synthesis, Schreiber & Schmitz 1996's surrogates made
//! endless): the surface is a Gaussian field `g` on a grid of [`SPACING_M`], an overlap-add of
//! stretches of [`STRETCH`] points, each the inverse FFT of complex Gaussian bins with the
//! per-band amplitudes of [`SurfaceStats::gauss_db`], windowed by `sin(π(n+½)/L)` so that two
//! neighbours' squared windows sum to 1 (unit variance everywhere). A monotone map
//! `h = rms · Q(Φ(g))` (Φ the normal CDF, Q the surface's quantile function) gives the heights the
//! measured distribution (Q read at the normal score g, [`height_at_score`]); `gauss_db` is the Gaussian field's band spectrum that the map turns into
//! the measured one (calibrated offline, where the data are derived). Stretch `k` is drawn from
//! `(seed, k)` alone, so the surface is a fixed function of position for a seed: a scraper going
//! back over a spot hears the same asperities, and none of it repeats at any distance.
//!
//! The audio thread never allocates: stretches and hop-length blocks of heights are computed on
//! demand into a few preallocated slots (one inverse FFT of [`STRETCH`] points per [`HOP`] points
//! travelled), and switching surfaces rewrites fixed-size tables.

use super::super::object::EngineRng;
use super::measured_data::SURFACE_STATS;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner};
use std::sync::Arc;

/// Grid spacing of the synthesised profiles, m: four of the microscope's 1.394068 µm pixels,
/// its stated horizontal resolution (5.6 µm). The bands end at 22.6 /mm, 0.126 cycles per
/// point, where the cubic interpolation loses under 0.3 dB.
pub const SPACING_M: f64 = 4.0 * 1.394_068e-6;
/// Points per stretch (one inverse FFT): 45.7 mm of surface, 4 bins in the lowest band.
pub const STRETCH: usize = 8192;
/// Points between stretch starts (50 % overlap).
pub const HOP: usize = STRETCH / 2;
/// Third-octave bands of spatial frequency, centres `2^(k/3)` per mm for
/// k = [`FIRST_BAND`]..: 0.354 – 22.6 /mm (wavelengths 44 µm – 2.83 mm), above the
/// roughness–waviness cut-off (ISO 4287's λc = 2.5 mm sits inside the lowest band) and below
/// what a tip's contact patch bridges at any speed (docs/model.md §6). At 0.5 m/s that is
/// 177 Hz – 11.3 kHz. Why not up to the scans' 47 /mm edge: there the height map's distortion
/// of a skewed distribution (sandpaper's grains) outweighs the measured spectrum, which lies
/// 6–10 dB under the next octave.
pub const BANDS: usize = 18;
/// k of the lowest third-octave band.
pub const FIRST_BAND: i32 = -4;
/// Octave bands (three third-octaves each), centres 0.5 – 16 /mm.
pub const OCTAVES: usize = BANDS / 3;
/// Entries of a height quantile table: the heights at the normal scores −[`Z_MAX`]..[`Z_MAX`]
/// in equal steps (probabilities Φ(z)). Why normal scores and not equal probabilities: the
/// Gaussian field maps through the table linearly in z, and the tails (a sandpaper grain, a
/// scratch) keep their shape; with equal probabilities the last 1/64 of the mass was spread
/// evenly up to the scan's largest outlier and the synthesised variance came out 3× too high.
pub const QUANTILES: usize = 65;
/// Largest normal score of the quantile table: 4σ (probability 3·10⁻⁵, one sample in a 2 mm
/// stretch of a scan); beyond it heights are clamped.
pub const Z_MAX: f64 = 5.0;
/// Slots of cached stretches and of cached blocks: three lines (the 2-D path) of two each, plus
/// room for a path turning around at a block boundary.
const SLOTS: usize = 8;
/// Offset between the three lines of the 2-D surface, m: far apart on the endless profile.
const LINE_OFFSET_M: f64 = 1_000.0;

/// Band edges in cycles per metre of third-octave band `b` (0-based).
pub fn band_edges_per_m(b: usize) -> (f64, f64) {
    let k = (FIRST_BAND + b as i32) as f64;
    (1e3 * 2f64.powf((k - 0.5) / 3.0), 1e3 * 2f64.powf((k + 0.5) / 3.0))
}

/// Statistics of one measured surface (generated, src/engine/sustained/measured_data.rs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceStats {
    /// Name as in scenes (`"pvc"`).
    pub name: &'static str,
    /// RMS height of the band-passed profile, m.
    pub rms_m: f64,
    /// Measured height power per third-octave band, dB re 1 µm² (sums to the variance).
    pub band_db: [f32; BANDS],
    /// Band power of the Gaussian field before the height map, dB (relative): calibrated so the
    /// mapped heights have `band_db`'s spectrum.
    pub gauss_db: [f32; BANDS],
    /// Unit-RMS heights at the normal scores [`score`]`(i)`.
    pub quantiles: [f32; QUANTILES],
}

/// The surface under a scraper or ball. In scene JSON: `"synthetic"` or a measured surface's name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceKind {
    /// The seeded fractal surface ([`super::Surface`]) whose RMS height the roughness sets.
    #[default]
    Synthetic,
    /// Cast acrylic sheet.
    Acrylic,
    /// Bass wood (linden).
    BassWood,
    /// Glazed ceramic.
    Ceramic,
    /// Plywood.
    Plywood,
    /// Polycarbonate sheet.
    Polycarbonate,
    /// Polyethylene.
    Polyethylene,
    /// Poplar wood.
    PoplarWood,
    /// PVC.
    Pvc,
    /// Rough (sawn) wood.
    RoughWood,
    /// Sanded acrylic.
    SandedAcrylic,
    /// Sandpaper.
    Sandpaper,
    /// Vinyl.
    Vinyl,
}

impl SurfaceKind {
    /// Every surface, synthetic first, then the measured ones in [`SURFACE_STATS`]' order.
    pub const ALL: [SurfaceKind; 13] = [
        SurfaceKind::Synthetic,
        SurfaceKind::Acrylic,
        SurfaceKind::BassWood,
        SurfaceKind::Ceramic,
        SurfaceKind::Plywood,
        SurfaceKind::Polycarbonate,
        SurfaceKind::Polyethylene,
        SurfaceKind::PoplarWood,
        SurfaceKind::Pvc,
        SurfaceKind::RoughWood,
        SurfaceKind::SandedAcrylic,
        SurfaceKind::Sandpaper,
        SurfaceKind::Vinyl,
    ];

    /// The scene names, in [`Self::ALL`]'s order.
    pub const NAMES: [&'static str; 13] = [
        "synthetic",
        "acrylic",
        "bass_wood",
        "ceramic",
        "plywood",
        "polycarbonate",
        "polyethylene",
        "poplar_wood",
        "pvc",
        "rough_wood",
        "sanded_acrylic",
        "sandpaper",
        "vinyl",
    ];

    /// The scene name (`"bass_wood"`).
    pub fn name(self) -> &'static str {
        Self::NAMES[self.index()]
    }

    /// Position in [`Self::ALL`] (the plugin's choice index).
    pub fn index(self) -> usize {
        self as usize
    }

    /// The measured statistics; `None` for the synthetic surface.
    pub fn stats(self) -> Option<&'static SurfaceStats> {
        self.index().checked_sub(1).and_then(|i| SURFACE_STATS.get(i))
    }

    /// The surface called `name` (scene spelling); the error names it and lists the valid ones.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL
            .iter()
            .copied()
            .find(|k| k.name() == name.trim())
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|k| k.name()).collect();
                format!("unknown surface `{name}`; expected one of {}", names.join(", "))
            })
    }
}

/// Standard normal CDF (Abramowitz & Stegun 7.1.26 for erf, |error| < 1.5e-7).
pub fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736 + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-z * z).exp();
    if x >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// The normal score of quantile-table entry `i`: −[`Z_MAX`] to +[`Z_MAX`] in equal steps.
pub fn score(i: usize) -> f64 {
    -Z_MAX + 2.0 * Z_MAX * i as f64 / (QUANTILES - 1) as f64
}

/// The height of a quantile table at normal score `z` (linear between entries, clamped to the
/// table's ends).
pub fn height_at_score(table: &[f32; QUANTILES], z: f64) -> f64 {
    let x = ((z + Z_MAX) / (2.0 * Z_MAX) * (QUANTILES - 1) as f64).clamp(0.0, (QUANTILES - 1) as f64);
    let i = (x as usize).min(QUANTILES - 2);
    let f = x - i as f64;
    table[i] as f64 * (1.0 - f) + table[i + 1] as f64 * f
}

/// The CDF of the height distribution a quantile table describes, at height `h` (unit RMS):
/// `Φ(z(h))` with `z` linear between entries; 0 below the first entry, 1 from the last.
pub fn table_cdf(table: &[f32; QUANTILES], h: f64) -> f64 {
    if h < table[0] as f64 {
        return 0.0;
    }
    if h >= table[QUANTILES - 1] as f64 {
        return 1.0;
    }
    let i = table
        .partition_point(|&q| (q as f64) <= h)
        .clamp(1, QUANTILES - 1)
        - 1;
    let (a, b) = (table[i] as f64, table[i + 1] as f64);
    let f = if b > a { (h - a) / (b - a) } else { 0.5 };
    normal_cdf(score(i) + f * (score(i + 1) - score(i)))
}

/// An endless profile with a measured surface's statistics, for one seed.
pub struct MeasuredSurface {
    kind: SurfaceKind,
    stats: Option<SurfaceStats>,
    seed: u64,
    c2r: Arc<dyn ComplexToReal<f64>>,
    spec: Vec<Complex<f64>>,
    time: Vec<f64>,
    scratch: Vec<Complex<f64>>,
    /// Per-bin amplitude of the stretches' spectra (bins 0..=STRETCH/2).
    amp: Vec<f64>,
    /// Third-octave band of each bin (`u8::MAX` outside the bands).
    bin_band: Vec<u8>,
    /// `sin(π(n+½)/L)`.
    window: Vec<f32>,
    /// Heights in m at the normal scores [`score`]`(i)` (the quantile table × RMS height).
    map: [f32; QUANTILES],
    stretches: Vec<f32>,
    stretch_key: [i64; SLOTS],
    stretch_used: [u64; SLOTS],
    blocks: Vec<f32>,
    block_key: [i64; SLOTS],
    block_used: [u64; SLOTS],
    last_block: usize,
    clock: u64,
    stretches_made: u64,
}

impl std::fmt::Debug for MeasuredSurface {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MeasuredSurface")
            .field("kind", &self.kind)
            .field("seed", &self.seed)
            .finish_non_exhaustive()
    }
}

impl Clone for MeasuredSurface {
    fn clone(&self) -> Self {
        let mut c = Self::new(self.seed);
        if let Some(s) = &self.stats {
            c.load(s);
        }
        c.kind = self.kind;
        c
    }
}

impl MeasuredSurface {
    /// An empty surface for `seed` (allocates: FFT plan and slots, ~400 KiB). Select a
    /// surface with [`Self::select`] before reading heights.
    pub fn new(seed: u64) -> Self {
        let c2r = RealFftPlanner::<f64>::new().plan_fft_inverse(STRETCH);
        let spec = c2r.make_input_vec();
        let time = c2r.make_output_vec();
        let scratch = c2r.make_scratch_vec();
        let period_m = STRETCH as f64 * SPACING_M;
        let bin_band = (0..=STRETCH / 2)
            .map(|j| {
                let f = j as f64 / period_m;
                (0..BANDS)
                    .find(|&b| {
                        let (lo, hi) = band_edges_per_m(b);
                        f >= lo && f < hi
                    })
                    .map_or(u8::MAX, |b| b as u8)
            })
            .collect();
        let window = (0..STRETCH)
            .map(|n| (std::f64::consts::PI * (n as f64 + 0.5) / STRETCH as f64).sin() as f32)
            .collect();
        Self {
            kind: SurfaceKind::Synthetic,
            stats: None,
            seed,
            c2r,
            spec,
            time,
            scratch,
            amp: vec![0.0; STRETCH / 2 + 1],
            bin_band,
            window,
            map: [0.0; QUANTILES],
            stretches: vec![0.0; SLOTS * STRETCH],
            stretch_key: [i64::MIN; SLOTS],
            stretch_used: [0; SLOTS],
            blocks: vec![0.0; SLOTS * HOP],
            block_key: [i64::MIN; SLOTS],
            block_used: [0; SLOTS],
            last_block: 0,
            clock: 0,
            stretches_made: 0,
        }
    }

    /// The selected surface.
    pub fn kind(&self) -> SurfaceKind {
        self.kind
    }

    /// Stretches synthesised since construction (tests, cost).
    pub fn stretches_made(&self) -> u64 {
        self.stretches_made
    }

    /// Selects `kind` (the synthetic one leaves heights at 0). Never allocates: it rewrites the
    /// spectrum and height-map tables and forgets the cached stretches.
    pub fn select(&mut self, kind: SurfaceKind) {
        self.kind = kind;
        match kind.stats() {
            Some(s) => self.load(s),
            None => self.stats = None,
        }
    }

    /// Uses `stats` directly (calibration and tests; [`Self::kind`] stays synthetic). Never
    /// allocates.
    pub fn set_stats(&mut self, stats: &SurfaceStats) {
        self.kind = SurfaceKind::Synthetic;
        self.load(stats);
    }

    /// A new seed (forgets the cached stretches). Never allocates.
    pub fn reseed(&mut self, seed: u64) {
        self.seed = seed;
        self.forget();
    }

    fn forget(&mut self) {
        self.stretch_key = [i64::MIN; SLOTS];
        self.block_key = [i64::MIN; SLOTS];
    }

    fn load(&mut self, s: &SurfaceStats) {
        self.stats = Some(*s);
        // Band powers (linear, normalised to unit variance) spread evenly over their bins; a
        // complex bin of mean power a² contributes 2a² to the variance of the real stretch.
        let mut count = [0usize; BANDS];
        for &b in &self.bin_band {
            if (b as usize) < BANDS {
                count[b as usize] += 1;
            }
        }
        let mut power = [0.0f64; BANDS];
        for (p, db) in power.iter_mut().zip(&s.gauss_db) {
            *p = 10f64.powf(*db as f64 / 10.0);
        }
        let total: f64 = power.iter().sum();
        for (a, &b) in self.amp.iter_mut().zip(&self.bin_band) {
            let b = b as usize;
            *a = if b < BANDS && count[b] > 0 && total > 0.0 {
                (power[b] / total / (2.0 * count[b] as f64)).sqrt()
            } else {
                0.0
            };
        }
        for (m, q) in self.map.iter_mut().zip(&s.quantiles) {
            *m = (s.rms_m * *q as f64) as f32;
        }
        self.forget();
    }

    /// Windowed Gaussian stretch `k` into slot `slot`. Never allocates.
    fn make_stretch(&mut self, k: i64, slot: usize) {
        let mix = (self.seed ^ 0x5afe_5ca1_e000_0001)
            .wrapping_mul(0x9e37_79b9_7f4a_7c15)
            .wrapping_add((k as u64).wrapping_mul(0xbf58_476d_1ce4_e5b9))
            ^ (self.kind as u64).wrapping_mul(0x94d0_49bb_1331_11eb);
        let mut rng = EngineRng::seed_from_u64(mix);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for (c, &a) in self.spec.iter_mut().zip(&self.amp) {
            if a > 0.0 {
                let re: f64 = rng.sample(StandardNormal);
                let im: f64 = rng.sample(StandardNormal);
                *c = Complex::new(a * h * re, a * h * im);
            } else {
                *c = Complex::new(0.0, 0.0);
            }
        }
        let out = &mut self.stretches[slot * STRETCH..(slot + 1) * STRETCH];
        // DC and Nyquist are outside the bands, so zero: the transform cannot fail.
        if self
            .c2r
            .process_with_scratch(&mut self.spec, &mut self.time, &mut self.scratch)
            .is_err()
        {
            out.iter_mut().for_each(|v| *v = 0.0);
        } else {
            for ((o, t), w) in out.iter_mut().zip(&self.time).zip(&self.window) {
                *o = *t as f32 * w;
            }
        }
        self.stretch_key[slot] = k;
        self.stretches_made += 1;
    }

    fn tick(&mut self) -> u64 {
        self.clock += 1;
        self.clock
    }

    fn stretch_slot(&mut self, k: i64) -> usize {
        let t = self.tick();
        if let Some(s) = self.stretch_key.iter().position(|&key| key == k) {
            self.stretch_used[s] = t;
            return s;
        }
        let s = lru(&self.stretch_used);
        self.make_stretch(k, s);
        self.stretch_used[s] = t;
        s
    }

    /// Slot of block `b` (points `b·HOP .. (b+1)·HOP`), computing it if needed.
    #[inline]
    fn block_slot(&mut self, b: i64) -> usize {
        if self.block_key[self.last_block] == b {
            return self.last_block;
        }
        let t = self.tick();
        let slot = match self.block_key.iter().position(|&key| key == b) {
            Some(s) => s,
            None => {
                let s = lru(&self.block_used);
                // Guard the block's slot while its stretches are made (they do not touch it).
                self.block_key[s] = i64::MIN;
                let cur = self.stretch_slot(b);
                let prev = self.stretch_slot(b - 1);
                let step = ((QUANTILES - 1) as f64 / (2.0 * Z_MAX)) as f32;
                let top = (QUANTILES - 1) as f32 - 1e-4;
                for n in 0..HOP {
                    let g = self.stretches[cur * STRETCH + n] + self.stretches[prev * STRETCH + HOP + n];
                    let x = ((g + Z_MAX as f32) * step).clamp(0.0, top);
                    let i = x as usize;
                    let f = x - i as f32;
                    self.blocks[s * HOP + n] = self.map[i] + f * (self.map[i + 1] - self.map[i]);
                }
                self.block_key[s] = b;
                s
            }
        };
        self.block_used[slot] = t;
        self.last_block = slot;
        slot
    }

    #[inline]
    fn point(&mut self, i: i64) -> f32 {
        let b = i.div_euclid(HOP as i64);
        let s = self.block_slot(b);
        self.blocks[s * HOP + (i - b * HOP as i64) as usize]
    }

    /// Height in m at `x_m` (any real position). Zero while the synthetic surface is selected.
    /// Never allocates; computes a stretch when the position enters new ground.
    #[inline]
    pub fn height_m(&mut self, x_m: f64) -> f64 {
        if self.stats.is_none() || !x_m.is_finite() {
            return 0.0;
        }
        let u = x_m * (1.0 / SPACING_M);
        let fl = u.floor();
        let t = (u - fl) as f32;
        let i = fl as i64;
        let (p0, p1, p2, p3) = {
            let b = (i - 1).div_euclid(HOP as i64);
            if (i + 2).div_euclid(HOP as i64) == b {
                let s = self.block_slot(b);
                let o = s * HOP + (i - 1 - b * HOP as i64) as usize;
                let w = &self.blocks[o..o + 4];
                (w[0], w[1], w[2], w[3])
            } else {
                (
                    self.point(i - 1),
                    self.point(i),
                    self.point(i + 1),
                    self.point(i + 2),
                )
            }
        };
        // Catmull–Rom, as the synthetic surface: the trajectory's slope has no steps.
        let a = -0.5 * p0 + 1.5 * p1 - 1.5 * p2 + 0.5 * p3;
        let b = p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3;
        let c = 0.5 * (p2 - p0);
        (((a * t + b) * t + c) * t + p1) as f64
    }

    /// Height in m at (x, y): three lines 60° apart (as [`super::Surface::height_2d`]), far
    /// apart on the profile, over √3.
    #[inline]
    pub fn height_2d_m(&mut self, x_m: f64, y_m: f64) -> f64 {
        const C60: f64 = 0.5;
        const S60: f64 = 0.866_025_403_784_438_6;
        let h = self.height_m(x_m)
            + self.height_m(C60 * x_m + S60 * y_m + LINE_OFFSET_M)
            + self.height_m(-C60 * x_m + S60 * y_m + 2.0 * LINE_OFFSET_M);
        h * (1.0 / 3.0f64.sqrt())
    }

    /// The grid points `start..start + out.len()` (heights in m), e.g. for statistics. Never
    /// allocates.
    pub fn fill_points(&mut self, start: i64, out: &mut [f64]) {
        if self.stats.is_none() {
            out.iter_mut().for_each(|v| *v = 0.0);
            return;
        }
        for (n, o) in out.iter_mut().enumerate() {
            *o = self.point(start + n as i64) as f64;
        }
    }
}

fn lru(used: &[u64; SLOTS]) -> usize {
    let mut best = 0;
    for (i, &u) in used.iter().enumerate() {
        if u < used[best] {
            best = i;
        }
    }
    best
}

/// Height power per third-octave band (m², summing to the variance in the bands) of a profile
/// sampled at `spacing_m`: the periodogram of the whole profile, mean removed, under a Tukey
/// window (cosine tapers over 5 % at each end, against the leakage of the ends' step). One
/// transform of the whole, not Welch's average of windowed segments: a scan's roughness is not
/// stationary (sandpaper's varies along it), and segment windows then weigh some stretches
/// more than others, so the bands no longer sum to the variance the height map reproduces. The
/// derivation and the tests use this one estimator. Allocates.
pub fn band_powers(profile: &[f64], spacing_m: f64) -> [f64; BANDS] {
    let n = profile.len();
    let mut out = [0.0; BANDS];
    if n < 64 {
        return out;
    }
    let r2c = RealFftPlanner::<f64>::new().plan_fft_forward(n);
    let taper = (0.05 * n as f64) as usize;
    let window = |i: usize| {
        let d = i.min(n - 1 - i);
        if d >= taper {
            1.0
        } else {
            0.5 - 0.5 * (std::f64::consts::PI * (d as f64 + 0.5) / taper as f64).cos()
        }
    };
    let mean = profile.iter().sum::<f64>() / n as f64;
    let mut buf: Vec<f64> = profile
        .iter()
        .enumerate()
        .map(|(i, x)| (x - mean) * window(i))
        .collect();
    let wss: f64 = (0..n).map(|i| window(i).powi(2)).sum();
    let mut spec = r2c.make_output_vec();
    if r2c.process(&mut buf, &mut spec).is_err() {
        return out;
    }
    let period_m = n as f64 * spacing_m;
    for (j, c) in spec.iter().enumerate() {
        let f = j as f64 / period_m;
        if let Some(b) = (0..BANDS).find(|&b| {
            let (lo, hi) = band_edges_per_m(b);
            f >= lo && f < hi
        }) {
            out[b] += 2.0 * c.norm_sqr() / (wss * n as f64);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for k in SurfaceKind::ALL {
            assert_eq!(SurfaceKind::from_name(k.name()), Ok(k));
            let json = format!("\"{}\"", k.name());
            assert_eq!(serde_json::from_str::<SurfaceKind>(&json).unwrap(), k);
        }
        let e = SurfaceKind::from_name("velvet").unwrap_err();
        assert!(e.contains("`velvet`") && e.contains("sandpaper"), "{e}");
        let e = serde_json::from_str::<SurfaceKind>("\"velvet\"")
            .unwrap_err()
            .to_string();
        assert!(e.contains("velvet"), "{e}");
    }

    /// A position reads the same height whatever path led there (the surface is a function of
    /// position per seed), seeds differ, and the synthetic choice reads 0.
    #[test]
    fn heights_depend_on_position_not_on_path() {
        let mut a = MeasuredSurface::new(3);
        let mut b = MeasuredSurface::new(3);
        a.select(SurfaceKind::Pvc);
        b.select(SurfaceKind::Pvc);
        let xs: Vec<f64> = (0..2000).map(|i| i as f64 * 7.3e-5 - 0.05).collect();
        let fwd: Vec<f64> = xs.iter().map(|&x| a.height_m(x)).collect();
        // b jumps far away first (evicting everything), then reads backwards.
        b.height_m(123.0);
        let back: Vec<f64> = xs.iter().rev().map(|&x| b.height_m(x)).collect();
        for (f, r) in fwd.iter().zip(back.iter().rev()) {
            assert_eq!(f, r);
        }
        assert!(fwd.iter().all(|h| h.is_finite()) && fwd.iter().any(|h| *h != 0.0));
        let mut c = MeasuredSurface::new(4);
        c.select(SurfaceKind::Pvc);
        assert_ne!(c.height_m(0.01), a.height_m(0.01));
        a.select(SurfaceKind::Synthetic);
        assert_eq!(a.height_m(0.01), 0.0);
    }
}
