//! Impact transient (Traer eq. 3): `h_T(t) = Σ_n 10^((α_n − β_n·t)/20)·ν_n(t)`, with `ν_n` white
//! noise through the n-th ERB-spaced band. Each band is a complex one-pole filter (bandwidth =
//! 1 ERB, normalised to unit output RMS) fed by its own seeded white noise, under its own
//! exponential envelope. Bands that have decayed below the floor stop costing anything.
//!
//! Why a noise per band: one-pole bands have Lorentzian skirts, so ERB-spaced neighbours
//! overlap by about a third of their power, and one shared noise made their outputs correlated:
//! a transient of several loud adjacent bands played 3–4 dB louder than the sum of its bands'
//! levels (the fitted cowbell's 4–9 kHz bands), which is what the fit assumes (its bands
//! partition the spectrum, so they add in power; docs/presets.md, "Known
//! limits").
//!
//! The transient is started by an impact and scaled by the contact impulse J (N·s): it is the
//! part of the object's IR that the force excites, `F(f)·h_T`. Each band is weighted by the
//! smooth envelope of the contact spectrum at its centre, `|F(f)|/J ≈ 1/√(1 + (2fτ)⁴)` for a
//! contact of duration τ (the half sine's `|cos(πfτ)|/|1 − (2fτ)²|` without the nulls that only
//! an idealised pulse has), so a heavier, longer contact also darkens the transient (Traer Exp. 3).
//!
//! Layout: struct of arrays in lane sets of 16 bands (`[f32; 16]`, one AVX-512 or two AVX2 registers), so the per-sample update of a lane
//! set compiles to SIMD; a lane set whose 16 envelopes all fell below the floor is dropped.

use super::dsp::scales::erb_bandwidth_hz;
use super::dsp::scales::hearing_threshold_power;
use super::dsp::simd::Kernel;
use super::object::ObjectBand;

/// Envelope level (linear output units) below which a band stops: −130 dBFS, the engine's
/// per-mode floor, well under the voices' −110 dBFS sleep floor; a lower floor keeps slow bands
/// of the fitted metal transient running for seconds of inaudible work.
const BAND_FLOOR: f32 = 3.162e-7;

/// Bands per SIMD lane set: one AVX-512 register, two AVX2 registers. 30 bands fill two sets.
const LANES: usize = 16;
type Lane = [f32; LANES];

/// Per-band noise generator states (xorshift32), one lane per band.
type LaneState = [u32; LANES];

/// Bank of decaying noise bands. Never allocates after construction.
#[derive(Debug, Clone)]
pub struct TransientBank {
    /// Active lane sets.
    active: usize,
    /// Bands in the active lane sets (dead lanes included), for work accounting.
    bands: usize,
    pr: Vec<Lane>,
    pi: Vec<Lane>,
    norm: Vec<Lane>,
    env: Vec<Lane>,
    env_step: Vec<Lane>,
    zr: Vec<Lane>,
    zi: Vec<Lane>,
    /// Per band: the threshold of hearing at its centre as a power relative to 0 dB SPL
    /// ([`hearing_threshold_power`]), for [`TransientBank::cull`].
    thr: Vec<Lane>,
    /// Per band: its noise generator's state, advanced once per sample (so the noise does not
    /// depend on how the host splits blocks), seeded from the hit's seed and the band's centre
    /// (so a band's noise does not depend on which other bands play).
    noise: Vec<LaneState>,
    kernel: Kernel,
}

impl TransientBank {
    /// Room for `capacity` bands (rounded up to a multiple of 16).
    pub fn with_capacity(capacity: usize) -> Self {
        let sets = capacity.div_ceil(LANES);
        let z = vec![[0.0; LANES]; sets];
        Self {
            active: 0,
            bands: 0,
            pr: z.clone(),
            pi: z.clone(),
            norm: z.clone(),
            env: z.clone(),
            env_step: z.clone(),
            zr: z.clone(),
            zi: z.clone(),
            thr: z,
            noise: vec![[0; LANES]; sets],
            kernel: Kernel::detect(),
        }
    }

    /// Bands currently computed (multiple of 16: dead lanes in a live set still cost).
    pub fn active(&self) -> usize {
        self.active * LANES
    }

    /// Starts the transient: `impulse_ns` scales all bands; `contact_duration_s` low-passes them
    /// (see module docs); `freq_scale` multiplies centres (object size); `decay_scale`
    /// multiplies decays; `seed` fixes the noise.
    #[allow(clippy::too_many_arguments)]
    pub fn start(
        &mut self,
        bands: &[ObjectBand],
        impulse_ns: f64,
        contact_duration_s: f64,
        freq_scale: f64,
        decay_scale: f64,
        sample_rate: f64,
        seed: u32,
    ) {
        let nyq = 0.49 * sample_rate;
        let tau = if contact_duration_s.is_finite() {
            contact_duration_s.max(0.0)
        } else {
            0.0
        };
        let cap = self.pr.len() * LANES;
        let mut n = 0;
        for b in bands {
            if n == cap {
                break;
            }
            let fc = b.centre_hz * freq_scale;
            if !(fc > 0.0 && fc < nyq) || !b.level_db.is_finite() || !b.decay_db_per_s.is_finite() {
                continue;
            }
            let bw = erb_bandwidth_hz(fc);
            let r = (-std::f64::consts::PI * bw / sample_rate).exp();
            let w = std::f64::consts::TAU * fc / sample_rate;
            let contact = 1.0 / (1.0 + (2.0 * fc * tau).powi(4)).sqrt();
            let amp = impulse_ns.abs() * contact * 10f64.powf(b.level_db / 20.0);
            if !(amp > BAND_FLOOR as f64) || !amp.is_finite() {
                continue;
            }
            let d = (b.decay_db_per_s * decay_scale).max(0.0);
            let (c, l) = (n / LANES, n % LANES);
            self.pr[c][l] = (r * w.cos()) as f32;
            self.pi[c][l] = (r * w.sin()) as f32;
            // Re(z) of a complex one-pole fed unit-variance noise has variance 1/(2(1−r²)).
            self.norm[c][l] = (2.0 * (1.0 - r * r)).sqrt() as f32;
            self.env[c][l] = amp as f32;
            self.env_step[c][l] = 10f64.powf(-d / 20.0 / sample_rate) as f32;
            self.zr[c][l] = 0.0;
            self.zi[c][l] = 0.0;
            self.thr[c][l] = hearing_threshold_power(fc) as f32;
            let bits = fc.to_bits();
            // xorshift32 has one fixed point, 0.
            self.noise[c][l] = lowbias32(seed ^ lowbias32((bits ^ (bits >> 32)) as u32 ^ 0x9E37_79B9)).max(1);
            n += 1;
        }
        // Unused lanes of the last set are silent.
        let sets = n.div_ceil(LANES);
        self.silence_lanes(n, sets * LANES);
        self.active = sets;
        self.bands = n;
    }

    /// Perceptual culling of the bands (docs/model.md §8, the modes' rules): a band ends when its
    /// envelope (its output RMS) is below `floor` (output units), or its power below
    /// `threshold_scale` × the threshold of hearing at its centre (`threshold_scale` =
    /// 10^(−L/10) for full scale played at L dB SPL; 0 disables this rule). A band's envelope only
    /// falls, so an ended band stays inaudible. The live bands are then packed into as few lane
    /// sets as they fill: the work is per lane set of 16, so ending bands here and there would
    /// otherwise save nothing. A band's noise state moves with it, so packing changes no sample
    /// beyond f32 summation order. Never allocates.
    pub fn cull(&mut self, floor: f32, threshold_scale: f64) {
        let mut n = 0;
        for c in 0..self.active {
            for l in 0..LANES {
                let e = self.env[c][l];
                let p = f64::from(e) * f64::from(e);
                if !(e > 0.0) || e < floor || p < f64::from(self.thr[c][l]) * threshold_scale {
                    continue;
                }
                let (dc, dl) = (n / LANES, n % LANES);
                if (dc, dl) != (c, l) {
                    for a in self.per_band() {
                        a[dc][dl] = a[c][l];
                    }
                    self.noise[dc][dl] = self.noise[c][l];
                }
                n += 1;
            }
        }
        self.silence_lanes(n, self.active * LANES);
        self.active = n.div_ceil(LANES);
        self.bands = n;
    }

    /// Every per-band array (a band's whole state is its lane in each).
    fn per_band(&mut self) -> [&mut Vec<Lane>; 8] {
        [
            &mut self.pr,
            &mut self.pi,
            &mut self.norm,
            &mut self.env,
            &mut self.env_step,
            &mut self.zr,
            &mut self.zi,
            &mut self.thr,
        ]
    }

    /// Zeroes every per-band value of lanes `from..to` (lane index = set × `LANES` + lane).
    fn silence_lanes(&mut self, from: usize, to: usize) {
        for a in self.per_band() {
            for i in from..to {
                a[i / LANES][i % LANES] = 0.0;
            }
        }
        for i in from..to {
            // Any non-zero state: the lane's envelope is 0.
            self.noise[i / LANES][i % LANES] = 1;
        }
    }

    /// Largest band envelope (0 when none).
    pub fn max_env(&self) -> f32 {
        self.env[..self.active]
            .iter()
            .flatten()
            .fold(0.0, |m, &e| m.max(e))
    }

    /// Stops everything.
    pub fn reset(&mut self) {
        self.active = 0;
        self.bands = 0;
    }

    /// Adds the transient to `out`; drops lane sets whose envelopes all fell below the floor.
    pub fn process(&mut self, out: &mut [f32]) {
        if self.active == 0 {
            return;
        }
        let a = self.active;
        let st = Bands {
            pr: &self.pr[..a],
            pi: &self.pi[..a],
            norm: &self.norm[..a],
            step: &self.env_step[..a],
            zr: &mut self.zr[..a],
            zi: &mut self.zi[..a],
            env: &mut self.env[..a],
            noise: &mut self.noise[..a],
        };
        dispatch(self.kernel, st, out);
        // Zero the envelopes of lanes that fell below the floor: a slow band keeps its lane group
        // alive, and the decayed lanes beside it would otherwise sink into f32 subnormals, where
        // every multiply costs ~100 cycles (this was 99 % of an impact's cost).
        for c in 0..self.active {
            for e in self.env[c].iter_mut() {
                if !(*e >= BAND_FLOOR) {
                    *e = 0.0;
                }
            }
        }
        let mut c = 0;
        while c < self.active {
            if self.env[c].iter().all(|&e| e == 0.0) {
                let last = self.active - 1;
                for a in self.per_band() {
                    a.swap(c, last);
                }
                self.noise.swap(c, last);
                self.active -= 1;
            } else {
                c += 1;
            }
        }
    }
}

/// Chris Wellons' "lowbias32" integer hash (a bijection on u32 with low bias), used to seed the
/// bands' noise generators.
#[inline(always)]
fn lowbias32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Borrowed view of the active lane sets for the kernels.
struct Bands<'a> {
    pr: &'a [Lane],
    pi: &'a [Lane],
    norm: &'a [Lane],
    step: &'a [Lane],
    zr: &'a mut [Lane],
    zi: &'a mut [Lane],
    env: &'a mut [Lane],
    noise: &'a mut [LaneState],
}

/// One sample of one lane set: advances its noise, filter and envelope, and adds its output to
/// `acc`. The one arithmetic both band loops share, so they render the same bits.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn band_step<const FMA: bool>(
    (pr, pi, norm, step): (&Lane, &Lane, &Lane, &Lane),
    zr: &mut Lane,
    zi: &mut Lane,
    env: &mut Lane,
    s: &mut LaneState,
    acc: &mut Lane,
) {
    let madd = |a: f32, x: f32, c: f32| if FMA { a.mul_add(x, c) } else { a * x + c };
    for l in 0..LANES {
        // xorshift32 → uniform in [−1, 1) scaled to unit variance (√3).
        s[l] ^= s[l] << 13;
        s[l] ^= s[l] >> 17;
        s[l] ^= s[l] << 5;
        let x = (s[l] as i32) as f32 * (1.732_050_8 / 2_147_483_648.0);
        let nr = madd(pr[l], zr[l], madd(-pi[l], zi[l], x * norm[l]));
        let ni = madd(pr[l], zi[l], pi[l] * zr[l]);
        acc[l] = madd(env[l], nr, acc[l]);
        zr[l] = nr;
        zi[l] = ni;
        env[l] *= step[l];
    }
}

/// Per-sample band recursion for `N` lane sets (an object's ≤ 64 bands take at most 4), samples
/// outer and lane sets inner. Each lane set's recursion is a serial chain, so interleaving the
/// sets lets their latencies overlap. Why the state is copied into locals for the whole block:
/// read and written through the slices every sample, the seven per-set state vectors cost more
/// loads and stores than the recursion's arithmetic (and the slices arrive through a struct, so
/// LLVM could not prove they do not alias and left the lanes scalar: 3.4 ns per band-sample).
#[inline(always)]
fn bands_held<const FMA: bool, const N: usize>(b: Bands<'_>, out: &mut [f32], hsum: impl Fn(&Lane) -> f32) {
    let load = |a: &[Lane]| -> [Lane; N] { std::array::from_fn(|c| a[c]) };
    let (pr, pi, norm, step) = (load(b.pr), load(b.pi), load(b.norm), load(b.step));
    let (mut zr, mut zi, mut env) = (load(b.zr), load(b.zi), load(b.env));
    let mut s: [LaneState; N] = std::array::from_fn(|c| b.noise[c]);
    for o in out.iter_mut() {
        let mut acc = [0f32; LANES];
        for c in 0..N {
            let coef = (&pr[c], &pi[c], &norm[c], &step[c]);
            band_step::<FMA>(coef, &mut zr[c], &mut zi[c], &mut env[c], &mut s[c], &mut acc);
        }
        // One horizontal sum per sample, in vector registers (LLVM turned the portable
        // pairwise sum into 15 scalar adds, half the kernel's time).
        *o += hsum(&acc);
    }
    b.zr[..N].copy_from_slice(&zr);
    b.zi[..N].copy_from_slice(&zi);
    b.env[..N].copy_from_slice(&env);
    b.noise[..N].copy_from_slice(&s);
}

/// The band recursion over however many lane sets are active: [`bands_held`] for up to 4 (every
/// object's bands), else the same arithmetic with the state in the slices.
#[inline(always)]
fn bands_generic<const FMA: bool>(b: Bands<'_>, out: &mut [f32], hsum: impl Fn(&Lane) -> f32) {
    let sets =
        b.pr.len()
            .min(b.pi.len())
            .min(b.norm.len())
            .min(b.step.len())
            .min(b.zr.len())
            .min(b.zi.len())
            .min(b.env.len())
            .min(b.noise.len());
    match sets {
        0 => {}
        1 => bands_held::<FMA, 1>(b, out, hsum),
        2 => bands_held::<FMA, 2>(b, out, hsum),
        3 => bands_held::<FMA, 3>(b, out, hsum),
        4 => bands_held::<FMA, 4>(b, out, hsum),
        _ => {
            for o in out.iter_mut() {
                let mut acc = [0f32; LANES];
                for c in 0..sets {
                    let coef = (&b.pr[c], &b.pi[c], &b.norm[c], &b.step[c]);
                    let (mut zr, mut zi, mut env, mut s) = (b.zr[c], b.zi[c], b.env[c], b.noise[c]);
                    band_step::<FMA>(coef, &mut zr, &mut zi, &mut env, &mut s, &mut acc);
                    (b.zr[c], b.zi[c], b.env[c], b.noise[c]) = (zr, zi, env, s);
                }
                *o += hsum(&acc);
            }
        }
    }
}

/// Pairwise lane sum (portable).
#[inline(always)]
fn hsum_portable(a: &Lane) -> f32 {
    let mut h = [0f32; LANES / 2];
    for l in 0..LANES / 2 {
        h[l] = a[l] + a[l + LANES / 2];
    }
    let mut q = [0f32; LANES / 4];
    for l in 0..LANES / 4 {
        q[l] = h[l] + h[l + LANES / 4];
    }
    (q[0] + q[2]) + (q[1] + q[3])
}

fn dispatch(kernel: Kernel, b: Bands<'_>, out: &mut [f32]) {
    match kernel {
        // SAFETY: `kernel`'s features were detected at runtime (`dsp::simd` invariant).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { bands_avx512(b, out) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { bands_avx2(b, out) },
        _ => bands_generic::<false>(b, out, hsum_portable),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn bands_avx512(b: Bands<'_>, out: &mut [f32]) {
    use std::arch::x86_64::*;
    // SAFETY (both intrinsics): AVX-512F is enabled for this function; the load reads exactly
    // the 16 f32 of the lane array.
    bands_generic::<true>(b, out, |a: &Lane| unsafe {
        _mm512_reduce_add_ps(_mm512_loadu_ps(a.as_ptr()))
    })
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn bands_avx2(b: Bands<'_>, out: &mut [f32]) {
    use std::arch::x86_64::*;
    // SAFETY: AVX2 is enabled for this function; the loads read the 16 f32 of the lane array.
    bands_generic::<true>(b, out, |a: &Lane| unsafe {
        let v = _mm256_add_ps(_mm256_loadu_ps(a.as_ptr()), _mm256_loadu_ps(a.as_ptr().add(8)));
        let x = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
        let x = _mm_add_ps(x, _mm_movehl_ps(x, x));
        _mm_cvtss_f32(_mm_add_ss(x, _mm_shuffle_ps::<1>(x, x)))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bands(n: usize) -> Vec<ObjectBand> {
        (0..n)
            .map(|i| ObjectBand {
                centre_hz: 200.0 * 1.2f64.powi(i as i32),
                level_db: -10.0,
                decay_db_per_s: 200.0 + 50.0 * i as f64,
            })
            .collect()
    }

    #[test]
    fn deterministic_finite_and_stops() {
        let b = bands(19);
        let run = |block: usize| {
            let mut t = TransientBank::with_capacity(64);
            t.start(&b, 0.1, 1e-4, 1.0, 1.0, 48_000.0, 99);
            assert_eq!(t.active(), 32, "19 bands → 2 lane sets of 16");
            let mut out = vec![0f32; 48_000];
            for ch in out.chunks_mut(block) {
                t.process(ch);
            }
            (out, t.active())
        };
        let (a, left) = run(512);
        let (b1, _) = run(1);
        let (c, _) = run(4096);
        assert!(a.iter().all(|v| v.is_finite()) && a.iter().any(|&v| v != 0.0));
        // Same seed: same noise and the same per-sample arithmetic whatever the block size.
        assert_eq!(a[..4096], b1[..4096]);
        assert_eq!(a[..4096], c[..4096]);
        // 200 dB/s from a −30 dB start reaches the −180 dB floor well within a second.
        assert_eq!(left, 0, "decayed bands must stop costing");
    }

    #[test]
    fn cull_ends_quiet_bands_and_packs_the_rest() {
        // 19 bands, 3 of them loud: after the cull only they remain, in one lane set, and
        // they sound as before (each band keeps its own noise; summation order aside).
        let mut b = bands(19);
        for (i, band) in b.iter_mut().enumerate() {
            band.decay_db_per_s = 50.0;
            if i % 7 != 3 {
                band.level_db = -80.0;
            }
        }
        let loud: Vec<ObjectBand> = b.iter().filter(|x| x.level_db > -50.0).cloned().collect();
        assert_eq!(loud.len(), 3);
        let mut all = TransientBank::with_capacity(64);
        let mut only = TransientBank::with_capacity(64);
        all.start(&b, 0.1, 1e-4, 1.0, 1.0, 48_000.0, 7);
        only.start(&loud, 0.1, 1e-4, 1.0, 1.0, 48_000.0, 7);
        let (mut x, mut y) = (vec![0f32; 256], vec![0f32; 256]);
        all.process(&mut x);
        only.process(&mut y);
        // Nothing below the floor yet: nothing ends, nothing moves.
        all.cull(1e-9, 0.0);
        assert_eq!(all.active(), 32);
        // 40 dB below the strongest band: the −80 dB bands end, the three loud ones pack.
        all.cull(all.max_env() * 0.01, 0.0);
        assert_eq!(all.active(), 16, "3 live bands fit one lane set");
        let (mut x, mut y) = (vec![0f32; 4096], vec![0f32; 4096]);
        all.process(&mut x);
        only.process(&mut y);
        let err = x.iter().zip(&y).fold(0f32, |m, (a, b)| m.max((a - b).abs()));
        let peak = y.iter().fold(0f32, |m, v| m.max(v.abs()));
        assert!(
            peak > 0.0 && err <= 1e-6 * peak,
            "packing changed the output: {err} vs {peak}"
        );
        // The threshold of hearing ends every band when full scale plays at −200 dB SPL.
        all.cull(0.0, 1e20);
        assert_eq!(all.active(), 0);
    }

    #[test]
    fn longer_contact_darkens() {
        let b = bands(19);
        let energy_hi = |tau: f64| {
            let mut t = TransientBank::with_capacity(64);
            t.start(&b[15..], 0.1, tau, 1.0, 1.0, 48_000.0, 5);
            let mut out = vec![0f32; 4800];
            t.process(&mut out);
            out.iter().map(|v| (*v as f64).powi(2)).sum::<f64>()
        };
        assert!(energy_hi(2e-3) < 0.1 * energy_hi(1e-5));
    }

    /// Adjacent ERB bands add in power, as the fit's bands do (they partition the spectrum):
    /// the energy of five loud, short, adjacent bands played together is the sum of their
    /// energies played alone. One noise shared by all bands made it 3–4 dB more (the one-pole
    /// bands' skirts overlap, so their outputs were correlated).
    #[test]
    fn adjacent_bands_add_in_power() {
        let mut centres = Vec::new();
        super::super::dsp::scales::erb_centres(30, 50.0, 16_000.0, &mut centres);
        let b: Vec<ObjectBand> = centres[20..25]
            .iter()
            .map(|&centre_hz| ObjectBand {
                centre_hz,
                level_db: 0.0,
                decay_db_per_s: 15_000.0,
            })
            .collect();
        let energy = |bands: &[ObjectBand]| {
            (0..256u32)
                .map(|seed| {
                    let mut t = TransientBank::with_capacity(16);
                    t.start(bands, 1.0, 0.0, 1.0, 1.0, 48_000.0, seed);
                    let mut out = vec![0f32; 4800];
                    t.process(&mut out);
                    out.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>()
                })
                .sum::<f64>()
        };
        let together = energy(&b);
        let alone: f64 = b.iter().map(|x| energy(std::slice::from_ref(x))).sum();
        let diff_db = 10.0 * (together / alone).log10();
        assert!(
            diff_db.abs() < 0.3,
            "together {diff_db:+.2} dB re the sum of the bands alone"
        );
    }
}
