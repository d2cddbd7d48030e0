//! Joint least squares of the cos/sin amplitudes of damped modes (with an optional attack) on
//! a signal: the inner loop of `extract`, blocked so that the basis stays in cache.

use crate::engine::dsp::DB_PER_NEPER;

/// Joint least squares of cos/sin amplitudes of all damped modes on `y`.
pub(super) fn joint_ls(y: &[f64], fs: f64, freqs: &[f64], decays: &[f64]) -> Vec<(f64, f64)> {
    joint_ls_attack(y, fs, freqs, decays, 0.0).0
}

/// Lanes of the partial sums of the least-squares fits' dot products: eight independent sums
/// let the compiler vectorise them (a plain iterator sum is one serial chain of additions).
const LANES: usize = 8;

/// Samples per block of the least-squares fits (a multiple of [`LANES`]). Why blocks: the
/// basis of a 150-mode fit over 0.5 s is 300 signals of 22 050 samples (53 MB); a block of all
/// of them (≤ 600 kB at 256 samples) stays in the 2 MB L2 cache while every pair's product is
/// summed, where whole-signal dot products streamed the basis from memory once per pair.
const BLOCK: usize = 256;

/// Largest basis (signals × samples) generated whole, once, for both passes of a fit (1 MB):
/// the one- and few-mode fits of the decay and attack searches, thousands per recording, then
/// generate their basis once instead of twice.
const WHOLE_BASIS_MAX: usize = 1 << 17;

/// The damped cosine and sine of one mode with its attack, generated block by block with the
/// recurrence of `extract::mode_signal_attack` (the same operations in the same order, so each
/// sample is bit-identical to that function's for amplitudes (1, 0) and (0, 1)).
#[derive(Clone, Copy)]
struct Oscillator {
    pr: f64,
    pi: f64,
    cr: f64,
    ci: f64,
    /// Attack state `e^{−i/τ}` and its step; both 0 without an attack, so that the attack
    /// factor `1 − g` is exactly 1.
    g: f64,
    q: f64,
}

impl Oscillator {
    fn new(f: f64, decay_db: f64, tau: f64, fs: f64) -> Self {
        let w = std::f64::consts::TAU * f / fs;
        let d = decay_db / DB_PER_NEPER / fs;
        let attack = tau > 0.0;
        Self {
            pr: 1.0,
            pi: 0.0,
            cr: (-d).exp() * w.cos(),
            ci: (-d).exp() * w.sin(),
            g: if attack { 1.0 } else { 0.0 },
            q: if attack { (-1.0 / tau).exp() } else { 0.0 },
        }
    }
}

/// Advances the `G` oscillators `o` together by `len` samples, writing oscillator l's cosine
/// to row `2l` and its sine to row `2l + 1` of `rows` (rows `stride` apart). Why together:
/// each recurrence is a serial chain of multiplies and adds, and one at a time leaves the CPU
/// waiting on that chain's latency.
#[inline(always)]
fn fill<const G: usize>(o: &mut [Oscillator], rows: &mut [f64], stride: usize, len: usize) {
    let o: &mut [Oscillator; G] = o.try_into().expect("G oscillators");
    let mut s = *o;
    let rows = &mut rows[..2 * G * stride];
    for t in 0..len {
        for (l, v) in s.iter_mut().enumerate() {
            let a = 1.0 - v.g;
            rows[2 * l * stride + t] = (1.0 * v.pr + 0.0 * v.pi) * a;
            rows[(2 * l + 1) * stride + t] = (0.0 * v.pr + 1.0 * v.pi) * a;
            let u = v.pr * v.cr - v.pi * v.ci;
            v.pi = v.pr * v.ci + v.pi * v.cr;
            v.pr = u;
            v.g *= v.q;
        }
    }
    *o = s;
}

/// The basis of a least-squares fit, generated a block at a time: row `2k` of a block is mode
/// k's damped cosine, row `2k + 1` its sine, rows `stride` apart.
struct BasisBlocks {
    oscs: Vec<Oscillator>,
    buf: Vec<f64>,
    stride: usize,
    len: usize,
}

impl BasisBlocks {
    fn new(fs: f64, freqs: &[f64], decays: &[f64], taus: &[f64], stride: usize) -> Self {
        let oscs: Vec<Oscillator> = (0..freqs.len())
            .map(|k| Oscillator::new(freqs[k], decays[k], taus[k], fs))
            .collect();
        let buf = vec![0.0; 2 * oscs.len() * stride];
        Self {
            oscs,
            buf,
            stride,
            len: 0,
        }
    }

    /// Generates the next `len` (≤ stride) samples of every basis signal.
    fn next(&mut self, len: usize) {
        self.len = len;
        let st = self.stride;
        let mut k = 0;
        while k + 4 <= self.oscs.len() {
            fill::<4>(&mut self.oscs[k..k + 4], &mut self.buf[2 * k * st..], st, len);
            k += 4;
        }
        while k < self.oscs.len() {
            fill::<1>(&mut self.oscs[k..k + 1], &mut self.buf[2 * k * st..], st, len);
            k += 1;
        }
    }

    /// Row `i` of the current block.
    fn row(&self, i: usize) -> &[f64] {
        &self.buf[i * self.stride..i * self.stride + self.len]
    }
}

/// Adds `a_i·b_i` into the lane `i mod 8` partial sums (`a.len()` a multiple of [`LANES`]).
fn accumulate(acc: &mut [f64; LANES], a: &[f64], b: &[f64]) {
    for (x, y) in a.chunks_exact(LANES).zip(b.chunks_exact(LANES)) {
        for k in 0..LANES {
            acc[k] += x[k] * y[k];
        }
    }
}

/// Adds row `a`'s products with samples `off..off + a.len()` of the first `cols` rows of
/// `basis` into their lane sums `acc` ([`accumulate`] for each, four rows per pass over `a` so
/// that each load of `a` serves four products; the sums are the same).
#[inline(always)]
fn accumulate_row_kernel(acc: &mut [[f64; LANES]], a: &[f64], basis: &BasisBlocks, off: usize, cols: usize) {
    let len = a.len() - a.len() % LANES;
    let a = &a[..len];
    let row = |j: usize| &basis.row(j)[off..off + len];
    let mut j = 0;
    while j + 4 <= cols {
        let (b0, b1, b2, b3) = (row(j), row(j + 1), row(j + 2), row(j + 3));
        let mut s = [acc[j], acc[j + 1], acc[j + 2], acc[j + 3]];
        let mut c = 0;
        while c < len {
            let x = &a[c..c + LANES];
            let (y0, y1, y2, y3) = (
                &b0[c..c + LANES],
                &b1[c..c + LANES],
                &b2[c..c + LANES],
                &b3[c..c + LANES],
            );
            for k in 0..LANES {
                s[0][k] += x[k] * y0[k];
                s[1][k] += x[k] * y1[k];
                s[2][k] += x[k] * y2[k];
                s[3][k] += x[k] * y3[k];
            }
            c += LANES;
        }
        acc[j..j + 4].copy_from_slice(&s);
        j += 4;
    }
    for j in j..cols {
        accumulate(&mut acc[j], a, row(j));
    }
}

/// [`accumulate_row_kernel`] compiled for AVX2 (four lanes per instruction; separate multiply
/// and add, no fused multiply-add, so the sums are bit-identical to the portable build).
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn accumulate_row_avx2(
    acc: &mut [[f64; LANES]],
    a: &[f64],
    basis: &BasisBlocks,
    off: usize,
    cols: usize,
) {
    accumulate_row_kernel(acc, a, basis, off, cols);
}

/// [`accumulate_row_kernel`] with AVX2 where `avx2` (detected) says the CPU has it.
fn accumulate_row(
    acc: &mut [[f64; LANES]],
    a: &[f64],
    basis: &BasisBlocks,
    off: usize,
    cols: usize,
    avx2: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` is true only where `is_x86_feature_detected!("avx2")` said so.
        unsafe { accumulate_row_avx2(acc, a, basis, off, cols) };
        return;
    }
    let _ = avx2;
    accumulate_row_kernel(acc, a, basis, off, cols);
}

/// `Σ a_i·b_i` of two signals from lane partial sums over their whole multiples of [`LANES`]
/// samples and the remaining samples' products `tail_a`, `tail_b`.
fn finish_dot(acc: &[f64; LANES], tail_a: &[f64], tail_b: &[f64]) -> f64 {
    let tail: f64 = tail_a.iter().zip(tail_b).map(|(x, y)| x * y).sum();
    acc.iter().sum::<f64>() + tail
}

/// As [`joint_ls`] with the attack `1 − e^{−i/τ}` on every mode (τ in samples, 0: none); also
/// returns the residual energy `Σ (y − model)²`.
pub(super) fn joint_ls_attack(
    y: &[f64],
    fs: f64,
    freqs: &[f64],
    decays: &[f64],
    tau: f64,
) -> (Vec<(f64, f64)>, f64) {
    joint_ls_taus(y, fs, freqs, decays, &vec![tau; freqs.len()])
}

/// As [`joint_ls_attack`] with each mode's own τ (samples). A large basis is never held whole:
/// it is generated in [`BLOCK`]-sample blocks, once for the Gram matrix and once for the
/// residual energy (a small one, up to [`WHOLE_BASIS_MAX`], is generated whole once). The dot
/// products keep per-pair lane sums across blocks, so every number is the same as for
/// whole-signal dot products with [`LANES`] partial sums.
pub(super) fn joint_ls_taus(
    y: &[f64],
    fs: f64,
    freqs: &[f64],
    decays: &[f64],
    taus: &[f64],
) -> (Vec<(f64, f64)>, f64) {
    let m = freqs.len();
    let p = 2 * m;
    let n = y.len();
    let whole = n - n % LANES;
    #[cfg(target_arch = "x86_64")]
    let avx2 = std::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    let avx2 = false;
    let at_once = p * n <= WHOLE_BASIS_MAX;
    let mut basis = BasisBlocks::new(fs, freqs, decays, taus, if at_once { n } else { BLOCK });
    if at_once {
        basis.next(n);
    }
    // Where samples `start..start + len` of every basis row lie in `basis`: at `start` of the
    // whole basis, or generated now at the start of the block buffer.
    let window = |basis: &mut BasisBlocks, start: usize, len: usize| {
        if at_once {
            start
        } else {
            basis.next(len);
            0
        }
    };
    // Lane sums of the lower triangle (row i, column j ≤ i at i(i+1)/2 + j) and of the
    // right-hand side.
    let mut gram_acc = vec![[0.0f64; LANES]; p * (p + 1) / 2];
    let mut rhs_acc = vec![[0.0f64; LANES]; p];
    let mut start = 0;
    while start < whole {
        let len = BLOCK.min(whole - start);
        let off = window(&mut basis, start, len);
        let yb = &y[start..start + len];
        for i in 0..p {
            let bi = &basis.row(i)[off..off + len];
            accumulate(&mut rhs_acc[i], bi, yb);
            let row = i * (i + 1) / 2;
            accumulate_row(&mut gram_acc[row..=row + i], bi, &basis, off, i + 1, avx2);
        }
        start += len;
    }
    let off = window(&mut basis, whole, n - whole);
    let tail = |i: usize| &basis.row(i)[off..off + n - whole];
    let yt = &y[whole..];
    let mut g = vec![vec![0.0; p]; p];
    let mut rhs = vec![0.0; p];
    for i in 0..p {
        rhs[i] = finish_dot(&rhs_acc[i], tail(i), yt);
        for j in 0..=i {
            let v = finish_dot(&gram_acc[i * (i + 1) / 2 + j], tail(i), tail(j));
            g[i][j] = v;
            g[j][i] = v;
        }
    }
    // Why a 1e-9 relative ridge: keeps nearly coincident modes solvable without biasing others.
    let tr = (0..p).map(|i| g[i][i]).sum::<f64>() / p.max(1) as f64;
    for i in 0..p {
        g[i][i] += 1e-9 * tr;
    }
    let sol = match crate::engine::dsp::linalg::cholesky(&g) {
        Some(l) => crate::engine::dsp::linalg::cholesky_solve(&l, &rhs),
        None => vec![0.0; p],
    };
    // Residual energy, each sample's residual formed in basis order.
    if !at_once {
        basis = BasisBlocks::new(fs, freqs, decays, taus, BLOCK);
    }
    let mut r = vec![0.0; BLOCK];
    let mut energy = 0.0;
    let mut start = 0;
    while start < n {
        let len = BLOCK.min(n - start);
        let off = window(&mut basis, start, len);
        let r = &mut r[..len];
        r.copy_from_slice(&y[start..start + len]);
        for (i, x) in sol.iter().enumerate() {
            for (ri, bi) in r.iter_mut().zip(&basis.row(i)[off..off + len]) {
                *ri -= x * bi;
            }
        }
        for v in r.iter() {
            energy += v * v;
        }
        start += len;
    }
    ((0..m).map(|k| (sol[2 * k], sol[2 * k + 1])).collect(), energy)
}
