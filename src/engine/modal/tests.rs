//! Tests of the bank: closed forms, kernel agreement, glides, retiring, masking in a bank.

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

/// The stereo bank (docs/model.md "Stereo pickups"): pans leave the mono render bit for bit;
/// the stereo mid is the mono sum and the side the sum with each gain times its side weight (up
/// to f32 rounding), through excitation, free ringing and partial steps; a bank with every mode
/// at the centre adds the mono render to the mid and nothing to the side.
#[test]
fn stereo_mid_is_the_mono_sum_and_side_the_weighted_sum() {
    use crate::engine::stereo::{pan_group, side_weight};
    let modes: Vec<_> = (0..37)
        .map(|i| mode(100.0 + 311.0 * i as f64, 2.0 + i as f64, 1.0 / (1.0 + i as f64)))
        .collect();
    let pans: Vec<u8> = (0..modes.len()).map(|i| pan_group(3, i)).collect();
    let side_modes: Vec<_> = modes
        .iter()
        .zip(&pans)
        .map(|(m, &p)| ModeParams {
            gain: m.gain * side_weight(p) as f32 as f64,
            ..*m
        })
        .collect();
    let x: Vec<f32> = (0..300).map(|n| if n % 97 == 3 { 0.01 } else { 0.0 }).collect();
    let len = 1000;
    for kernel in kernels() {
        let bank = |m: &[ModeParams], p: &[u8]| {
            let mut b = ModalBank::with_capacity(40);
            b.set_kernel(kernel);
            b.set_sample_rate(48_000.0);
            b.set_modes_panned(m, p);
            b
        };
        // Blocks of 100: excited, then free, with partial K-steps in both.
        let mono = |b: &mut ModalBank| {
            let mut out = vec![0.0f32; len];
            for (i, o) in out.chunks_mut(100).enumerate() {
                let at = i * 100;
                b.process((at < x.len()).then(|| &x[at..at + 100]), o);
            }
            out
        };
        let stereo = |b: &mut ModalBank| {
            let (mut m, mut s) = (vec![0.0f32; len], vec![0.0f32; len]);
            for (i, (mo, so)) in m.chunks_mut(100).zip(s.chunks_mut(100)).enumerate() {
                let at = i * 100;
                b.process_stereo((at < x.len()).then(|| &x[at..at + 100]), mo, so);
            }
            (m, s)
        };
        let plain = mono(&mut bank(&modes, &[]));
        assert_eq!(
            mono(&mut bank(&modes, &pans)),
            plain,
            "{kernel:?}: pans changed the mono render"
        );
        let (mid, side) = stereo(&mut bank(&modes, &pans));
        if bank(&modes, &pans).side_per_mode() {
            assert_eq!(
                mid, plain,
                "{kernel:?}: the per-mode stereo mid is the mono render"
            );
        }
        let side_ref = mono(&mut bank(&side_modes, &[]));
        let peak = plain.iter().fold(0.0f32, |a, v| a.max(v.abs()));
        let err = |a: &[f32], b: &[f32]| a.iter().zip(b).fold(0.0f32, |e, (x, y)| e.max((x - y).abs()));
        assert!(
            err(&mid, &plain) < 1e-5 * peak,
            "{kernel:?}: mid {}",
            err(&mid, &plain)
        );
        assert!(
            err(&side, &side_ref) < 1e-5 * peak,
            "{kernel:?}: side {}",
            err(&side, &side_ref)
        );
        assert!(side.iter().any(|&v| v.abs() > 0.01 * peak), "{kernel:?}: no side");
        let (mid, side) = stereo(&mut bank(&modes, &[]));
        assert_eq!(mid, plain, "{kernel:?}: centred bank's mid");
        assert!(side.iter().all(|&v| v == 0.0), "{kernel:?}: centred bank's side");
    }
}

/// Free-ringing banks rendered as one batch (`ModalBank::process_stereo_free_batch`) give the
/// sum of their own stereo renders up to f32 rounding: more banks than one batch holds, a
/// centred bank and an empty one among them, partial K-steps, and every bank's state advanced
/// as if rendered alone.
#[test]
fn stereo_batch_is_the_sum_of_its_banks() {
    use crate::engine::stereo::pan_group;
    let n_banks = STEREO_BATCH + 3;
    let make = |kernel: Kernel| -> Vec<ModalBank> {
        (0..n_banks)
            .map(|b| {
                let modes: Vec<_> = (0..5 + 7 * (b % 5))
                    .map(|i| {
                        mode(
                            90.0 + 173.0 * (i + b) as f64,
                            1.0 + i as f64,
                            1.0 / (1.0 + (i + b) as f64),
                        )
                    })
                    .collect();
                let pans: Vec<u8> = (0..modes.len()).map(|i| pan_group(b as u64, i)).collect();
                let mut bank = ModalBank::with_capacity(64);
                bank.set_kernel(kernel);
                bank.set_sample_rate(48_000.0);
                // Bank 1 centred, bank 2 empty.
                match b {
                    1 => bank.set_modes(&modes),
                    2 => bank.set_modes(&[]),
                    _ => bank.set_modes_panned(&modes, &pans),
                }
                let x = [0.01f32; 3];
                let mut sink = [0.0f32; 3];
                bank.process(Some(&x), &mut sink);
                bank
            })
            .collect()
    };
    let len = 250;
    for kernel in kernels() {
        let mut alone = make(kernel);
        let (mut mid, mut side) = (vec![0.0f32; len], vec![0.0f32; len]);
        for b in &mut alone {
            for (m, s) in mid.chunks_mut(100).zip(side.chunks_mut(100)) {
                b.process_stereo(None, m, s);
            }
        }
        let mut together = make(kernel);
        let (mut bmid, mut bside) = (vec![0.0f32; len], vec![0.0f32; len]);
        for (m, s) in bmid.chunks_mut(100).zip(bside.chunks_mut(100)) {
            let mut refs: Vec<Option<&mut ModalBank>> = together.iter_mut().map(Some).collect();
            ModalBank::process_stereo_free_batch(&mut refs, m, s);
        }
        let peak = mid.iter().fold(0.0f32, |a, v| a.max(v.abs()));
        let err = |a: &[f32], b: &[f32]| a.iter().zip(b).fold(0.0f32, |e, (x, y)| e.max((x - y).abs()));
        assert!(peak > 0.0 && side.iter().any(|&v| v != 0.0));
        assert!(
            err(&bmid, &mid) < 1e-5 * peak,
            "{kernel:?}: mid {}",
            err(&bmid, &mid)
        );
        assert!(
            err(&bside, &side) < 1e-5 * peak,
            "{kernel:?}: side {}",
            err(&bside, &side)
        );
        for (a, b) in alone.iter().zip(&together) {
            assert_eq!(a.active(), b.active());
            for i in 0..a.active() {
                assert!((a.magnitude(i) - b.magnitude(i)).abs() <= 1e-12 * a.magnitude(i).max(1e-30));
            }
        }
    }
}

/// The stereo batch's pan-sorted runs follow the bank: after retirements (one row moved each)
/// and glides ([`ModalBank::set_mode`]) the batch still gives the banks' own stereo renders.
#[test]
fn stereo_batch_follows_retirement_and_glides() {
    use crate::engine::stereo::pan_group;
    let make = |kernel: Kernel| -> Vec<ModalBank> {
        (0..5)
            .map(|b| {
                let modes: Vec<_> = (0..40)
                    .map(|i| {
                        mode(
                            120.0 + 151.0 * (i + b) as f64,
                            20.0 + 300.0 * (i % 7) as f64,
                            1.0 / (1.0 + i as f64),
                        )
                    })
                    .collect();
                let pans: Vec<u8> = (0..modes.len()).map(|i| pan_group(b as u64 + 11, i)).collect();
                let mut bank = ModalBank::with_capacity(64);
                bank.set_kernel(kernel);
                bank.set_sample_rate(48_000.0);
                bank.set_modes_panned(&modes, &pans);
                let mut sink = [0.0f32; 1];
                bank.process(Some(&[0.01]), &mut sink);
                bank
            })
            .collect()
    };
    for kernel in kernels() {
        let (mut alone, mut together) = (make(kernel), make(kernel));
        let mut retired = 0;
        for round in 0..6 {
            let len = 2000;
            let (mut mid, mut side) = (vec![0.0f32; len], vec![0.0f32; len]);
            let (mut bmid, mut bside) = (vec![0.0f32; len], vec![0.0f32; len]);
            for b in &mut alone {
                for (m, s) in mid.chunks_mut(100).zip(side.chunks_mut(100)) {
                    b.process_stereo(None, m, s);
                }
            }
            for (m, s) in bmid.chunks_mut(100).zip(bside.chunks_mut(100)) {
                let mut refs: Vec<Option<&mut ModalBank>> = together.iter_mut().map(Some).collect();
                ModalBank::process_stereo_free_batch(&mut refs, m, s);
            }
            let peak = mid.iter().fold(0.0f32, |a, v| a.max(v.abs()));
            let err = |a: &[f32], b: &[f32]| a.iter().zip(b).fold(0.0f32, |e, (x, y)| e.max((x - y).abs()));
            assert!(peak > 0.0);
            assert!(
                err(&bmid, &mid) < 1e-5 * peak,
                "{kernel:?} round {round}: mid {}",
                err(&bmid, &mid)
            );
            assert!(
                err(&bside, &side) < 1e-5 * peak,
                "{kernel:?} round {round}: side {}",
                err(&bside, &side)
            );
            for (a, b) in alone.iter_mut().zip(&mut together) {
                let before = a.active();
                assert_eq!(a.retire_below(2e-4), b.retire_below(2e-4));
                retired += before - a.active();
                if a.active() > 1 {
                    let m = mode(500.0 + 37.0 * round as f64, 5.0, 0.5);
                    assert!(a.set_mode(1, m) && b.set_mode(1, m));
                }
            }
        }
        assert!(retired > 20, "{kernel:?}: {retired} retired");
    }
}
