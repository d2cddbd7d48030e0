//! The measured surfaces' statistics from their scans (`tactus surfaces derive`): reads the
//! twelve `.npy` depth profiles Agarwal et al. 2021 measured (shipped with PyImpact), settles
//! their sample spacing and units, and writes the compact tables the engine synthesises endless
//! surfaces from (src/engine/sustained/measured_data.rs; docs/model.md §6 "Measured surfaces").
//!
//! What the data say (printed by the command, figures in docs/model.md):
//! - Every file is band-limited with a brick-wall edge (≥ 35 dB within 10 % in frequency) at the
//!   same number of cycles per file, 6 660–6 710, whatever its length (100 800 or 387 693 –
//!   403 490 samples): each is a resampling of a scan of the same ~13 400 resolved points. The
//!   seven short files at PyImpact's 1.394068 µm span 140.5 mm; read at that spacing the long
//!   files would span 4× that and resolve 4× coarser detail. Tactus reads all twelve as the
//!   same 140.5 mm scan ([`SCAN_LENGTH_M`]): a long file's spacing is 140.5 mm over its samples
//!   (0.348–0.362 µm), its resolved band the short ones' (wavelengths ≥ 21 µm).
//! - `sanded_acrylic`'s heights are 1000× those of its file ([`UNIT_FIXES`]): at file scale its
//!   RMS is 0.6 nm, six steps of the microscope's 0.1 nm vertical resolution, yet its spectrum
//!   spans over 30 dB with acrylic's shape and no quantisation floor; ×1000 puts its band levels
//!   within a few dB of acrylic's.

use crate::engine::sustained::measured::{
    band_edges_per_m, band_powers, normal_cdf, score, MeasuredSurface, SurfaceKind, SurfaceStats, BANDS,
    QUANTILES, SPACING_M,
};
use anyhow::{bail, Context};
use realfft::RealFftPlanner;
use std::path::Path;

/// Length of every scan, m: the short files' 100 800 samples at PyImpact's 1.394068 µm.
pub const SCAN_LENGTH_M: f64 = 100_800.0 * 1.394_068e-6;
/// Height scale factors of files whose units slipped (see the module docs).
pub const UNIT_FIXES: &[(&str, f64)] = &[("sanded_acrylic", 1000.0)];
/// Profile dropped at each end after the band-pass, m: the longest band's wavelength.
pub const EDGE_TRIM_M: f64 = 2.83e-3;
/// Calibration rounds of the Gaussian field's band spectrum.
pub const CALIBRATION_ROUNDS: usize = 8;
/// Grid points per calibration round (1.46 m of surface).
pub const CALIBRATION_POINTS: usize = 1 << 19;

/// A depth profile read from a `.npy` file: a 1-D array of float64 or float32.
pub fn read_profile(path: &Path) -> anyhow::Result<Vec<f64>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let npy = npyz::NpyFile::new(&bytes[..])
        .map_err(|e| anyhow::anyhow!("{}: not a NumPy .npy file: {e}", path.display()))?;
    let shape = npy.shape().to_vec();
    if shape.len() != 1 {
        bail!(
            "{}: a surface profile must be a 1-D float array, got shape {shape:?}",
            path.display()
        );
    }
    let dtype = npy.dtype();
    // The dtype as NumPy writes it (a Python literal, `'<f8'`).
    let descr = dtype.descr().trim_matches('\'').to_string();
    let data: Vec<f64> = match descr.trim_start_matches(['<', '>', '=', '|']) {
        "f8" => npy
            .into_vec::<f64>()
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?,
        "f4" => npy
            .into_vec::<f32>()
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?
            .into_iter()
            .map(f64::from)
            .collect(),
        _ => bail!(
            "{}: a surface profile must be a 1-D float array, got dtype {descr}",
            path.display()
        ),
    };
    if data.len() < 1000 {
        bail!(
            "{}: a surface profile needs at least 1000 samples, got {}",
            path.display(),
            data.len()
        );
    }
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        bail!("{}: sample {i} is not a finite number", path.display());
    }
    Ok(data)
}

/// One derived surface with what was measured on its file.
#[derive(Debug, Clone)]
pub struct Derived {
    /// The statistics shipped.
    pub stats: SurfaceStats,
    /// Samples in the file.
    pub samples: usize,
    /// Sample spacing read from the data, m.
    pub spacing_m: f64,
    /// Height factor applied ([`UNIT_FIXES`]).
    pub scale: f64,
    /// Where the file's spectrum has its band-limit edge, cycles per file.
    pub edge_cycles: f64,
    /// RMS of the file's heights (linear trend removed), m, after `scale`.
    pub rms_raw_m: f64,
    /// Octave-band levels of a synthesised stretch minus the measured ones, dB (seed 1).
    pub check_db: [f64; BANDS / 3],
}

/// Where the spectrum drops steepest (over 10 % in frequency), cycles per file, searched in
/// 3 000 – 12 000 cycles per file (the edge of every file lies there; the long files' resampling
/// artefacts lie above it).
fn band_edge_cycles(x: &[f64]) -> f64 {
    let n = 1 << 16;
    let p = band_powers_fine(x, n);
    let per_file = x.len() as f64 / n as f64;
    let sm: Vec<f64> = (0..p.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(8).max(1), (k + 8).min(p.len()));
            10.0 * (p[a..b].iter().sum::<f64>() / (b - a) as f64).max(1e-300).log10()
        })
        .collect();
    let (lo, hi) = (
        (3000.0 / per_file) as usize,
        ((12_000.0 / per_file) as usize).min(p.len() * 10 / 11),
    );
    let mut best = (f64::NEG_INFINITY, lo);
    for k in lo.max(16)..hi {
        let d = sm[k] - sm[k * 11 / 10];
        if d > best.0 {
            best = (d, k);
        }
    }
    best.1 as f64 * per_file
}

/// Welch periodogram (Hann, 50 %) per bin of `n`-point segments.
fn band_powers_fine(x: &[f64], n: usize) -> Vec<f64> {
    let r2c = RealFftPlanner::<f64>::new().plan_fft_forward(n);
    let w: Vec<f64> = (0..n)
        .map(|i| (std::f64::consts::PI * i as f64 / n as f64).sin().powi(2))
        .collect();
    let mut acc = vec![0.0; n / 2 + 1];
    let (mut buf, mut out) = (r2c.make_input_vec(), r2c.make_output_vec());
    let mut s = 0;
    while s + n <= x.len() {
        let seg = &x[s..s + n];
        let m = seg.iter().sum::<f64>() / n as f64;
        for ((b, v), w) in buf.iter_mut().zip(seg).zip(&w) {
            *b = (v - m) * w;
        }
        if r2c.process(&mut buf, &mut out).is_ok() {
            for (a, o) in acc.iter_mut().zip(&out) {
                *a += o.norm_sqr();
            }
        }
        s += n / 2;
    }
    acc
}

fn detrend(x: &mut [f64]) {
    let n = x.len() as f64;
    let mx = (n - 1.0) / 2.0;
    let my = x.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, v) in x.iter().enumerate() {
        sxy += (i as f64 - mx) * (v - my);
        sxx += (i as f64 - mx).powi(2);
    }
    let b = sxy / sxx;
    for (i, v) in x.iter_mut().enumerate() {
        *v -= my + b * (i as f64 - mx);
    }
}

/// The profile band-passed to the synthesis bands: FFT of the file followed by its mirror image
/// (a periodic signal without a step where the ends meet, whose brick-wall filtering would ring
/// at both ends), the first half kept.
fn band_pass(x: &[f64], spacing_m: f64) -> anyhow::Result<Vec<f64>> {
    let mirrored: Vec<f64> = x.iter().chain(x.iter().rev()).copied().collect();
    let x = &mirrored[..];
    let n = x.len();
    let mut planner = RealFftPlanner::<f64>::new();
    let r2c = planner.plan_fft_forward(n);
    let c2r = planner.plan_fft_inverse(n);
    let mut buf = x.to_vec();
    let mut spec = r2c.make_output_vec();
    r2c.process(&mut buf, &mut spec)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let (lo, hi) = (band_edges_per_m(0).0, band_edges_per_m(BANDS - 1).1);
    let period = n as f64 * spacing_m;
    for (j, c) in spec.iter_mut().enumerate() {
        let f = j as f64 / period;
        if !(f >= lo && f < hi) {
            *c = realfft::num_complex::Complex::new(0.0, 0.0);
        }
    }
    let mut out = c2r.make_output_vec();
    c2r.process(&mut spec, &mut out)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    out.iter_mut().for_each(|v| *v /= n as f64);
    out.truncate(n / 2);
    Ok(out)
}

/// `x` (spacing `from_m`) at the synthesis grid's spacing, by linear interpolation (the content
/// lies far below either grid's Nyquist).
fn resample(x: &[f64], from_m: f64) -> Vec<f64> {
    let len = ((x.len() - 1) as f64 * from_m / SPACING_M) as usize;
    (0..len)
        .map(|j| {
            let u = j as f64 * SPACING_M / from_m;
            let i = (u as usize).min(x.len() - 2);
            let f = u - i as f64;
            x[i] * (1.0 - f) + x[i + 1] * f
        })
        .collect()
}

fn to_db_um2(p: f64) -> f64 {
    10.0 * (p / 1e-12).max(1e-30).log10()
}

/// Octave-band levels (dB re 1 µm²) from third-octave band powers (m²).
pub fn octave_db(p: &[f64; BANDS]) -> [f64; BANDS / 3] {
    std::array::from_fn(|o| to_db_um2(p[3 * o] + p[3 * o + 1] + p[3 * o + 2]))
}

/// Octave-band levels (dB re 1 µm²) of third-octave levels in dB re 1 µm².
pub fn octave_db_of(db: &[f32; BANDS]) -> [f64; BANDS / 3] {
    let p: [f64; BANDS] = std::array::from_fn(|b| 1e-12 * 10f64.powf(db[b] as f64 / 10.0));
    octave_db(&p)
}

/// `seed`'s synthesised surface under `stats`, `points` grid points from 0.
pub fn synthesise(stats: &SurfaceStats, seed: u64, points: usize) -> Vec<f64> {
    let mut s = MeasuredSurface::new(seed);
    s.set_stats(stats);
    let mut out = vec![0.0; points];
    s.fill_points(0, &mut out);
    out
}

/// Derives one surface from its scan.
pub fn derive_one(kind: SurfaceKind, path: &Path) -> anyhow::Result<Derived> {
    let name = kind.name();
    let mut x = read_profile(path)?;
    let scale = UNIT_FIXES
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(1.0, |(_, s)| *s);
    x.iter_mut().for_each(|v| *v *= scale);
    let edge_cycles = band_edge_cycles(&x);
    let spacing_m = SCAN_LENGTH_M / x.len() as f64;
    detrend(&mut x);
    let rms_raw_m = (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt();
    let r = resample(&band_pass(&x, spacing_m)?, spacing_m);
    // The longest band's wavelength at each end is filtered from one side only.
    let trim = (EDGE_TRIM_M / SPACING_M) as usize;
    let r = r[trim..r.len() - trim].to_vec();
    let rms_m = (r.iter().map(|v| v * v).sum::<f64>() / r.len() as f64).sqrt();
    if !(rms_m > 0.0) {
        bail!(
            "{}: the profile has no height variation in the surface bands",
            path.display()
        );
    }
    let mut sorted: Vec<f64> = r.iter().map(|v| v / rms_m).collect();
    sorted.sort_by(f64::total_cmp);
    let quantiles: [f32; QUANTILES] = std::array::from_fn(|i| {
        let u = normal_cdf(score(i)) * (sorted.len() - 1) as f64;
        let k = (u as usize).min(sorted.len() - 2);
        let f = u - k as f64;
        (sorted[k] * (1.0 - f) + sorted[k + 1] * f) as f32
    });
    let measured = band_powers(&r, SPACING_M);
    let band_db: [f32; BANDS] = std::array::from_fn(|b| to_db_um2(measured[b]) as f32);
    let mut stats = SurfaceStats {
        name,
        rms_m,
        band_db,
        gauss_db: band_db,
        quantiles,
    };
    // The height map reshapes the spectrum a little; correct the Gaussian field's bands by the
    // error of the mapped output, on one seed (common random numbers: the rounds converge
    // without sampling noise; the tests check other seeds).
    for _ in 0..CALIBRATION_ROUNDS {
        let out = band_powers(&synthesise(&stats, 0, CALIBRATION_POINTS), SPACING_M);
        for b in 0..BANDS {
            let err = band_db[b] as f64 - to_db_um2(out[b]);
            stats.gauss_db[b] = (stats.gauss_db[b] as f64 + err) as f32;
        }
    }
    let check = octave_db(&band_powers(
        &synthesise(&stats, 1, CALIBRATION_POINTS),
        SPACING_M,
    ));
    let target = octave_db_of(&band_db);
    let check_db = std::array::from_fn(|o| check[o] - target[o]);
    Ok(Derived {
        stats,
        samples: read_len(path)?,
        spacing_m,
        scale,
        edge_cycles,
        rms_raw_m,
        check_db,
    })
}

fn read_len(path: &Path) -> anyhow::Result<usize> {
    Ok(read_profile(path)?.len())
}

/// Derives every measured surface from `dir/<name>.npy`.
pub fn derive_all(dir: &Path) -> anyhow::Result<Vec<Derived>> {
    use rayon::prelude::*;
    SurfaceKind::ALL[1..]
        .par_iter()
        .map(|&k| derive_one(k, &dir.join(format!("{}.npy", k.name()))))
        .collect()
}

/// The data's licence notice, carried by every file derived from them.
pub const NOTICE: &str = "Copyright 2020 Massachusetts Institute of Technology

Redistribution and use in source and binary forms, with or without modification, are permitted
provided that the following conditions are met:

1. Redistributions of source code must retain the above copyright notice, this list of
   conditions and the following disclaimer.

2. Redistributions in binary form must reproduce the above copyright notice, this list of
   conditions and the following disclaimer in the documentation and/or other materials provided
   with the distribution.

THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS \"AS IS\" AND ANY EXPRESS OR
IMPLIED WARRANTIES, INCLUDING, BUT NOT LIMITED TO, THE IMPLIED WARRANTIES OF MERCHANTABILITY AND
FITNESS FOR A PARTICULAR PURPOSE ARE DISCLAIMED. IN NO EVENT SHALL THE COPYRIGHT HOLDER OR
CONTRIBUTORS BE LIABLE FOR ANY DIRECT, INDIRECT, INCIDENTAL, SPECIAL, EXEMPLARY, OR CONSEQUENTIAL
DAMAGES (INCLUDING, BUT NOT LIMITED TO, PROCUREMENT OF SUBSTITUTE GOODS OR SERVICES; LOSS OF USE,
DATA, OR PROFITS; OR BUSINESS INTERRUPTION) HOWEVER CAUSED AND ON ANY THEORY OF LIABILITY,
WHETHER IN CONTRACT, STRICT LIABILITY, OR TORT (INCLUDING NEGLIGENCE OR OTHERWISE) ARISING IN ANY
WAY OUT OF THE USE OF THIS SOFTWARE, EVEN IF ADVISED OF THE POSSIBILITY OF SUCH DAMAGE.";

fn floats(v: &[f32]) -> String {
    v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ")
}

/// The generated Rust source of `measured_data.rs`.
pub fn render_rust(derived: &[Derived]) -> String {
    let mut s = String::new();
    s.push_str(
        "//! Statistics of the twelve measured surfaces (docs/model.md §6 \"Measured surfaces\").\n\
         //! Generated by `tactus surfaces derive ../shared/measured/surfaces -o \
         src/engine/sustained/measured_data.rs`\n\
         //! from the depth profiles of Agarwal, Cusimano, Traer & McDermott 2021, as published with\n\
         //! PyImpact (tdw 1.13.0.0, `scrape_surfaces/*.npy`); do not edit. Derived from data under\n\
         //! this notice (also in presets/measured/LICENSE):\n//!\n",
    );
    for line in NOTICE.lines() {
        if line.is_empty() {
            s.push_str("//!\n");
        } else {
            s.push_str(&format!("//! {line}\n"));
        }
    }
    s.push_str("\nuse super::measured::SurfaceStats;\n\n");
    s.push_str(
        "/// Per measured surface, in [`super::measured::SurfaceKind::ALL`]'s order after `Synthetic`.\n",
    );
    s.push_str("#[rustfmt::skip]\n");
    s.push_str(&format!(
        "pub static SURFACE_STATS: [SurfaceStats; {}] = [\n",
        derived.len()
    ));
    for d in derived {
        let st = &d.stats;
        s.push_str(&format!(
            "    // {} samples, spacing {:.4} µm, height factor {}, band edge {:.0} cycles per file\n",
            d.samples,
            d.spacing_m * 1e6,
            d.scale,
            d.edge_cycles
        ));
        s.push_str(&format!(
            "    SurfaceStats {{\n        name: {:?},\n        rms_m: {:e},\n        band_db: [{}],\n        gauss_db: [{}],\n        quantiles: [{}],\n    }},\n",
            st.name,
            st.rms_m,
            floats(&st.band_db),
            floats(&st.gauss_db),
            floats(&st.quantiles)
        ));
    }
    s.push_str("];\n");
    s
}
