//! Accuracy of the modal bank (docs/model.md §2, Traer eq. 2) against the f64 reference
//! (`tactus::engine::reference`): SNR of a metal-like object, per-mode frequency (cent) and T60
//! error by a lagged Prony least-squares fit, long-term level of undamped modes, block-size
//! independence, parameter guards, glides. Every kernel variant the CPU supports is tested.

use tactus::engine::modal::{Kernel, ModalBank, ModeParams, MAX_FREQ_FRACTION};
use tactus::engine::reference::{render_modes_f64, render_modes_f64_recursive, snr_db};
use tactus::engine::stereo::{pan_group, side_weight};

const FS: f64 = 48_000.0;

fn kernels() -> Vec<Kernel> {
    [Kernel::Portable, Kernel::Avx2, Kernel::Avx512]
        .into_iter()
        .filter(|k| k.is_supported())
        .collect()
}

/// Deterministic uniform [0, 1) (64-bit LCG, top 53 bits).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Metal-like modes: inharmonic 150 Hz–20 kHz, decays 0.3–30 dB/s, levels over 40 dB.
fn metal_modes(n: usize, seed: u64) -> Vec<ModeParams> {
    let mut r = Lcg(seed);
    (0..n)
        .map(|_| {
            let t = r.next();
            let f = 150.0 * (20_000.0f64 / 150.0).powf(t);
            ModeParams {
                freq_hz: f,
                decay_db_per_s: 0.3 + 30.0 * t * t,
                gain: 10f64.powf(-2.0 * r.next()) * if r.next() < 0.5 { -1.0 } else { 1.0 },
            }
        })
        .collect()
}

/// Renders `len` samples: the impulse `input` (N·s per sample, may be shorter than `len`) while
/// it lasts, then free ringing, in blocks of `block`.
fn render(bank: &mut ModalBank, input: &[f32], len: usize, block: usize) -> Vec<f32> {
    let mut out = vec![0.0f32; len];
    let mut n = 0;
    while n < len {
        let b = block.min(len - n);
        if n < input.len() {
            let e = (n + b).min(input.len());
            bank.process(Some(&input[n..e]), &mut out[n..e]);
            n = e;
        } else {
            bank.process(None, &mut out[n..n + b]);
            n += b;
        }
    }
    out
}

fn bank_with(modes: &[ModeParams], kernel: Kernel) -> ModalBank {
    let mut b = ModalBank::with_capacity(modes.len().max(1));
    assert_eq!(b.set_kernel(kernel), kernel);
    b.set_sample_rate(FS);
    b.set_modes(modes);
    b
}

fn to_f64(v: &[f32]) -> Vec<f64> {
    v.iter().map(|&x| x as f64).collect()
}

#[test]
fn metal_object_10_s_snr_vs_f64_closed_form() {
    let modes = metal_modes(64, 7);
    let len = (10.0 * FS) as usize;
    // Two hits: the second lands while the first still rings (exercises the excited path).
    let mut x = vec![0.0f64; 24_001];
    x[0] = 1e-2;
    x[24_000] = -4e-3;
    let reference = render_modes_f64(&modes, FS, &x, len);
    let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    for kernel in kernels() {
        let mut bank = bank_with(&modes, kernel);
        let y = render(&mut bank, &x32, len, 256);
        let snr = snr_db(&reference, &to_f64(&y));
        println!("{kernel:?}: SNR over 10 s, 64 modes = {snr:.1} dB");
        assert!(snr >= 80.0, "{kernel:?}: SNR {snr:.1} dB");
    }
}

#[test]
fn dense_input_snr_vs_f64_recursion() {
    // Scraping-like: a noise impulse every sample for 0.5 s, then ringing to 1 s.
    let modes = metal_modes(32, 11);
    let mut r = Lcg(3);
    let x: Vec<f32> = (0..24_000).map(|_| ((r.next() - 0.5) * 1e-4) as f32).collect();
    let len = 48_000;
    // The reference sees the same f32 input.
    let reference = render_modes_f64_recursive(&modes, FS, &to_f64(&x), len);
    for kernel in kernels() {
        let mut bank = bank_with(&modes, kernel);
        let y = render(&mut bank, &x, len, 128);
        let snr = snr_db(&reference, &to_f64(&y));
        println!("{kernel:?}: SNR dense input = {snr:.1} dB");
        assert!(snr >= 80.0, "{kernel:?}: SNR {snr:.1} dB");
    }
}

/// The stereo bank (docs/model.md "Stereo pickups") against the f64 references: its mid against
/// the modes, its side against the modes with each gain times its pan group's side weight, over
/// the two-hit metal object and the dense input, with blocks of 333 (partial steps). Same
/// thresholds as the mono bank's.
#[test]
fn stereo_mid_and_side_snr_vs_f64() {
    let cases: [(Vec<ModeParams>, Vec<f32>, usize, usize); 2] = [
        {
            let mut x = vec![0.0f32; 24_001];
            x[0] = 1e-2;
            x[24_000] = -4e-3;
            (metal_modes(64, 7), x, (10.0 * FS) as usize, 333)
        },
        {
            let mut r = Lcg(3);
            let x = (0..24_000).map(|_| ((r.next() - 0.5) * 1e-4) as f32).collect();
            (metal_modes(32, 11), x, 48_000, 128)
        },
    ];
    for (modes, x, len, block) in cases {
        let pans: Vec<u8> = (0..modes.len()).map(|i| pan_group(5, i)).collect();
        let side_modes: Vec<ModeParams> = modes
            .iter()
            .zip(&pans)
            .map(|(m, &p)| ModeParams {
                gain: m.gain * side_weight(p) as f32 as f64,
                ..*m
            })
            .collect();
        let mid_ref = render_modes_f64_recursive(&modes, FS, &to_f64(&x), len);
        let side_ref = render_modes_f64_recursive(&side_modes, FS, &to_f64(&x), len);
        for kernel in kernels() {
            let mut bank = bank_with(&modes, kernel);
            bank.set_modes_panned(&modes, &pans);
            let (mut mid, mut side) = (vec![0.0f32; len], vec![0.0f32; len]);
            let mut n = 0;
            while n < len {
                let e = (n + block).min(len);
                let input = (n < x.len()).then(|| &x[n..e.min(x.len())]);
                bank.process_stereo(input, &mut mid[n..e], &mut side[n..e]);
                n = e;
            }
            let (sm, ss) = (snr_db(&mid_ref, &to_f64(&mid)), snr_db(&side_ref, &to_f64(&side)));
            println!(
                "{kernel:?}, {} modes: SNR mid {sm:.1} dB, side {ss:.1} dB",
                modes.len()
            );
            assert!(
                sm >= 80.0 && ss >= 80.0,
                "{kernel:?}: mid {sm:.1} dB, side {ss:.1} dB"
            );
        }
    }
}

/// Lagged Prony fit of a single damped cosine: for lag L,
/// `y[n+L] = 2·r^L·cos(Lω)·y[n] − r^{2L}·y[n−L]` exactly. Least squares over all n gives
/// `(ω, d)` in radians and nepers per sample. L is chosen so Lω ≈ π/2 (best conditioning).
fn prony_fit(y: &[f64], w_guess: f64) -> (f64, f64) {
    let l = ((std::f64::consts::FRAC_PI_2 / w_guess).round() as usize).max(1);
    let (mut s11, mut s12, mut s22, mut t1, mut t2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for n in l..y.len() - l {
        let (u, v, t) = (y[n], y[n - l], y[n + l]);
        s11 += u * u;
        s12 += u * v;
        s22 += v * v;
        t1 += u * t;
        t2 += v * t;
    }
    let det = s11 * s22 - s12 * s12;
    let a = (t1 * s22 - t2 * s12) / det;
    let b = (s11 * t2 - s12 * t1) / det;
    let r2l = -b;
    let d = -r2l.ln() / (2.0 * l as f64);
    let rl = r2l.sqrt();
    let w = (a / (2.0 * rl)).clamp(-1.0, 1.0).acos() / l as f64;
    (w, d)
}

#[test]
fn frequency_and_t60_per_mode() {
    let cases = [
        (55.0, 1.0),
        (440.0, 3.0),
        (1_234.5, 0.5),
        (5_000.0, 12.0),
        (12_000.0, 40.0),
        (23_000.0, 8.0),
        (0.4899 * FS, 2.0),
    ];
    let len = (2.0 * FS) as usize;
    let mut worst_cent: f64 = 0.0;
    let mut worst_t60: f64 = 0.0;
    for &(f, db) in &cases {
        let m = ModeParams {
            freq_hz: f,
            decay_db_per_s: db,
            gain: 1.0,
        };
        let (d_true, w_true) = m.pole(FS).unwrap();
        // The estimator itself must be exact on the f64 reference (so the test can fail only
        // because of the bank).
        let r = render_modes_f64_recursive(&[m], FS, &[1.0], len);
        let (w_ref, d_ref) = prony_fit(&r, w_true);
        assert!(
            (w_ref / w_true - 1.0).abs() < 1e-9 && (d_ref / d_true - 1.0).abs() < 1e-6,
            "estimator on the reference: {w_ref} vs {w_true}, {d_ref} vs {d_true}"
        );
        for kernel in kernels() {
            let mut bank = bank_with(&[m], kernel);
            let y = to_f64(&render(&mut bank, &[1.0], len, 512));
            let (w, d) = prony_fit(&y, w_true);
            let cent = 1200.0 * (w / w_true).log2();
            // T60 ∝ 1/d.
            let t60_err = d_true / d - 1.0;
            worst_cent = worst_cent.max(cent.abs());
            worst_t60 = worst_t60.max(t60_err.abs());
            assert!(cent.abs() <= 0.01, "{kernel:?} {f} Hz: {cent} cent");
            assert!(
                t60_err.abs() <= 1e-3,
                "{kernel:?} {f} Hz {db} dB/s: T60 error {t60_err}"
            );
        }
    }
    println!("worst frequency error {worst_cent:.2e} cent, worst T60 error {worst_t60:.2e}");
}

#[test]
fn undamped_modes_hold_level_over_10_minutes() {
    // Whole cycles per second at 48 kHz, so a 1 s RMS is exact: RMS² = Σ g²/2.
    let modes = [
        ModeParams {
            freq_hz: 1_000.0,
            decay_db_per_s: 0.0,
            gain: 1.0,
        },
        ModeParams {
            freq_hz: 6_000.0,
            decay_db_per_s: 0.0,
            gain: 0.5,
        },
        ModeParams {
            freq_hz: 0.48 * FS,
            decay_db_per_s: 0.0,
            gain: 0.25,
        },
    ];
    let expect_rms = ((1.0f64 + 0.25 + 0.0625) / 2.0).sqrt();
    let sec = FS as usize;
    for kernel in kernels() {
        let mut bank = bank_with(&modes, kernel);
        let mut out = vec![0.0f32; sec];
        // Second 0: the impulse sample, then ringing.
        bank.process(Some(&[1.0]), &mut out[..1]);
        let mut worst_db: f64 = 0.0;
        for s in 0..600 {
            let start = if s == 0 { 1 } else { 0 };
            if s > 0 {
                out.iter_mut().for_each(|v| *v = 0.0);
            }
            for c in out[start..].chunks_mut(512) {
                bank.process(None, c);
            }
            if s % 60 == 0 || s == 599 {
                let rms = (out.iter().map(|&v| (v as f64).powi(2)).sum::<f64>() / sec as f64).sqrt();
                let db = 20.0 * (rms / expect_rms).log10();
                worst_db = worst_db.max(db.abs());
                assert!(db.abs() <= 0.01, "{kernel:?} at {s} s: {db} dB");
                for (i, m) in modes.iter().enumerate() {
                    let db = 20.0 * (bank.magnitude(i) / m.gain).log10();
                    assert!(db.abs() <= 1e-4, "{kernel:?} mode {i} at {s} s: {db} dB");
                }
            }
        }
        assert!(out.iter().all(|v| v.is_finite()));
        println!("{kernel:?}: worst output level error over 10 min {worst_db:.2e} dB");
    }
}

#[test]
fn block_size_independence() {
    let modes = metal_modes(64, 5);
    let mut r = Lcg(9);
    // A 300-sample contact force then ringing.
    let x: Vec<f32> = (0..300)
        .map(|n| ((std::f64::consts::PI * n as f64 / 300.0).sin() * 1e-4 * (0.5 + r.next())) as f32)
        .collect();
    let len = 20_000;
    for kernel in kernels() {
        let runs: Vec<Vec<f32>> = [1usize, 37, 64, 4096]
            .iter()
            .map(|&b| render(&mut bank_with(&modes, kernel), &x, len, b))
            .collect();
        let peak = runs[0].iter().fold(0.0f32, |a, v| a.max(v.abs()));
        assert!(peak > 0.0);
        for (i, run) in runs.iter().enumerate().skip(1) {
            let err = run
                .iter()
                .zip(&runs[0])
                .fold(0.0f32, |a, (p, q)| a.max((p - q).abs()));
            assert!(
                err <= 1e-5 * peak,
                "{kernel:?} run {i}: error {err} vs peak {peak}"
            );
        }
    }
}

#[test]
fn modes_at_or_above_049_fs_are_dropped() {
    let mut bank = ModalBank::with_capacity(8);
    bank.set_sample_rate(FS);
    let f = |hz: f64| ModeParams {
        freq_hz: hz,
        decay_db_per_s: 0.0,
        gain: 1.0,
    };
    bank.set_modes(&[
        f(MAX_FREQ_FRACTION * FS),
        f(0.499 * FS),
        f(0.5 * FS),
        f(0.4899 * FS),
        f(30_000.0),
    ]);
    assert_eq!(bank.active(), 1);
    assert_eq!(bank.mode(0).unwrap().freq_hz, 0.4899 * FS);
    // Lowering the sample rate drops modes that no longer fit.
    bank.set_sample_rate(44_100.0);
    assert_eq!(bank.active(), 0);
}

#[test]
fn non_finite_params_are_rejected() {
    let mut bank = ModalBank::with_capacity(8);
    let bad = [
        (f64::NAN, 1.0, 1.0),
        (f64::INFINITY, 1.0, 1.0),
        (440.0, f64::NAN, 1.0),
        (440.0, f64::INFINITY, 1.0),
        (440.0, 1.0, f64::NAN),
        (440.0, 1.0, f64::NEG_INFINITY),
        (0.0, 1.0, 1.0),
        (-100.0, 1.0, 1.0),
    ];
    let modes: Vec<ModeParams> = bad
        .iter()
        .map(|&(freq_hz, decay_db_per_s, gain)| ModeParams {
            freq_hz,
            decay_db_per_s,
            gain,
        })
        .collect();
    bank.set_modes(&modes);
    assert_eq!(bank.active(), 0);
    bank.set_sample_rate(f64::NAN);
    bank.set_modes(&[ModeParams {
        freq_hz: 440.0,
        decay_db_per_s: 1.0,
        gain: 1.0,
    }]);
    assert_eq!(bank.active(), 1, "a NaN sample rate is ignored");
}

#[test]
fn output_finite_at_0_4899_fs_undamped_under_heavy_excitation() {
    let m = ModeParams {
        freq_hz: 0.4899 * FS,
        decay_db_per_s: 0.0,
        gain: 1.0,
    };
    for kernel in kernels() {
        let mut bank = bank_with(&[m], kernel);
        // Near-resonant excitation (alternating sign ≈ fs/2) for 10 s, then 1 s of ringing.
        let x: Vec<f32> = (0..(10.0 * FS) as usize)
            .map(|n| if n % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let y = render(&mut bank, &x, (11.0 * FS) as usize, 512);
        assert!(y.iter().all(|v| v.is_finite()), "{kernel:?}");
        assert!(y.iter().any(|v| v.abs() > 1.0), "{kernel:?}: the mode was driven");
    }
}

#[test]
fn glide_is_continuous() {
    let m = |f: f64| ModeParams {
        freq_hz: f,
        decay_db_per_s: 0.0,
        gain: 1.0,
    };
    for kernel in kernels() {
        let mut bank = bank_with(&[m(1_000.0)], kernel);
        let mut y = vec![0.0f32; 64 * 200];
        bank.process(Some(&[1.0]), &mut y[..1]);
        bank.process(None, &mut y[1..64]);
        for b in 1..200 {
            // A 1 kHz → 3 kHz glide, one step per 64-sample block.
            assert!(bank.set_mode(0, m(1_000.0 + 10.0 * b as f64)));
            bank.process(None, &mut y[b * 64..(b + 1) * 64]);
        }
        // No click: a unit cosine at ≤ 3 kHz moves at most ω per sample.
        let w_max = std::f64::consts::TAU * 3_000.0 / FS;
        let jump = y
            .windows(2)
            .fold(0.0f64, |a, w| a.max((w[1] - w[0]).abs() as f64));
        assert!(jump <= w_max * 1.001, "{kernel:?}: jump {jump} > {w_max}");
        assert!((bank.magnitude(0) - 1.0).abs() < 1e-9, "{kernel:?}: level kept");
    }
}
