//! Scraping and rolling force generators (src/engine/sustained): properties that can fail.

use realfft::RealFftPlanner;
use tactus::engine::sustained::{motion, ContactKind, Motion, MotionKind, SustainedParams, SustainedVoice};

const FS: f64 = 48_000.0;

/// Renders `n` samples of force in newtons (impulse·fs), block by block.
fn render(v: &mut SustainedVoice, p: &SustainedParams, n: usize, block: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(n);
    let mut buf = vec![0.0f32; block];
    let fs = v.sample_rate();
    while out.len() < n {
        let m = block.min(n - out.len());
        let live = v.process(p, None, &mut buf[..m]);
        out.extend(buf[..m].iter().map(|&x| if live { x as f64 * fs } else { 0.0 }));
    }
    out
}

fn scrape(speed: f64) -> SustainedParams {
    SustainedParams {
        kind: ContactKind::Scrape,
        motion: MotionKind::Manual,
        scrape_speed_m_per_s: speed,
        pressure_n: 5.0,
        roughness: 1.0,
        ..Default::default()
    }
}

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

/// Energy above and below `split_hz` (f64 FFT).
fn band_energy(x: &[f64], fs: f64, split_hz: f64) -> (f64, f64) {
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(x.len());
    let mut input = x.to_vec();
    let mut spec = fft.make_output_vec();
    fft.process(&mut input, &mut spec).unwrap();
    let (mut lo, mut hi) = (0.0, 0.0);
    for (k, c) in spec.iter().enumerate() {
        let f = k as f64 * fs / x.len() as f64;
        if f >= split_hz {
            hi += c.norm_sqr();
        } else {
            lo += c.norm_sqr();
        }
    }
    (lo, hi)
}

#[test]
fn curvature_limit_lowers_energy_above_5khz() {
    let p = scrape(1.0);
    let mut on = SustainedVoice::new(FS, 3);
    let mut off = SustainedVoice::new(FS, 3);
    off.curvature_limit = false;
    let a = render(&mut on, &p, 48_000, 512);
    let b = render(&mut off, &p, 48_000, 512);
    let (lo_a, hi_a) = band_energy(&a, FS, 5_000.0);
    let (lo_b, hi_b) = band_energy(&b, FS, 5_000.0);
    eprintln!(
        "hf on {hi_a:.3e} off {hi_b:.3e} ratio {:.3e}; lf on {lo_a:.3e} off {lo_b:.3e}",
        hi_a / hi_b
    );
    assert!(hi_a < 0.5 * hi_b, "limit on {hi_a} vs off {hi_b}");
    // And relative to its own low band, i.e. the limit reshapes the spectrum, not just the level.
    assert!(hi_a / lo_a < hi_b / lo_b);
}

#[test]
fn force_rms_rises_monotonically_with_speed() {
    let speeds = [0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0];
    let mut last = 0.0;
    for &s in &speeds {
        let mut v = SustainedVoice::new(FS, 11);
        let f = render(&mut v, &scrape(s), 24_000, 512);
        let r = rms(&f[2_400..]);
        eprintln!("speed {s} m/s: force rms {r:.4e} N");
        assert!(r > last, "rms {r} at {s} m/s not above {last}");
        last = r;
    }
}

#[test]
fn back_and_forth_has_speed_zeros_and_normal_swing_at_motion_rate() {
    let speed = 0.5;
    let w = speed / motion::BACK_AND_FORTH_HALF_M;
    let half_period_s = std::f64::consts::PI / w;
    let mut m = Motion::new(FS, 1);
    let n = (3.0 * half_period_s * FS) as usize;
    let mut vs = Vec::with_capacity(n);
    let mut ns = Vec::with_capacity(n);
    for _ in 0..n {
        let s = m.tick(MotionKind::BackAndForth, speed, 5.0, 0.0);
        vs.push(s.vx_m_per_s);
        ns.push(s.normal_n);
    }
    // Speed zeros (sign changes) exactly every half period.
    let zeros: Vec<f64> = (1..n)
        .filter(|&i| vs[i - 1] * vs[i] < 0.0)
        .map(|i| i as f64 / FS)
        .collect();
    assert_eq!(zeros.len(), 2, "{zeros:?}");
    for (k, z) in zeros.iter().enumerate() {
        assert!(
            (z - (k + 1) as f64 * half_period_s).abs() < 2.0 / FS,
            "zero at {z}"
        );
    }
    // N swings around the pressure at the motion rate: max at the near end (t = 0, 2π/ω), min at
    // the far end (t = π/ω), with the paper's N_max/N_min ratio (1 + Lω²A/g)/(1 − Lω²A/g).
    let (imax, imin) = (0, (half_period_s * FS).round() as usize);
    let swing = motion::LEVER_M * w * w * motion::BACK_AND_FORTH_HALF_M / motion::G_M_PER_S2;
    assert!((ns[imax] - 5.0 * (1.0 + swing)).abs() < 1e-6, "{}", ns[imax]);
    assert!((ns[imin] - 5.0 * (1.0 - swing)).abs() < 1e-3, "{}", ns[imin]);
    let nmax = ns.iter().cloned().fold(f64::MIN, f64::max);
    let nmin = ns.iter().cloned().fold(f64::MAX, f64::min);
    assert!((nmax - ns[imax]).abs() < 1e-6 && (nmin - ns[imin]).abs() < 1e-4);

    // The rendered force follows: around a speed zero it is far weaker than at peak speed.
    let p = SustainedParams {
        motion: MotionKind::BackAndForth,
        scrape_speed_m_per_s: speed,
        ..scrape(speed)
    };
    let mut v = SustainedVoice::new(FS, 5);
    let f = render(&mut v, &p, n, 256);
    let win = (0.01 * FS) as usize;
    let at_zero = rms(&f[imin - win..imin + win]);
    let peak_i = imin / 2;
    let at_peak = rms(&f[peak_i - win..peak_i + win]);
    eprintln!("force rms at speed zero {at_zero:.3e} N, at peak speed {at_peak:.3e} N");
    assert!(at_zero < 0.2 * at_peak);
}

#[test]
fn rolling_force_envelope_is_modulated_at_rotation_rate() {
    let (speed, radius) = (0.5, 0.02);
    let f_rot = speed / (std::f64::consts::TAU * radius);
    let p = SustainedParams {
        kind: ContactKind::Roll,
        roll_speed_m_per_s: speed,
        roll_radius_m: radius,
        roll_eccentricity: 0.2,
        pressure_n: 2.0,
        roughness: 0.5,
        ..Default::default()
    };
    let mut v = SustainedVoice::new(FS, 9);
    let secs = 4.0;
    let f = render(&mut v, &p, (secs * FS) as usize, 512);
    // Envelope of the audible part: first difference (suppresses the sub-audio rolling sinusoid,
    // whose rectified RMS would sit at 2·f_rot), then RMS over 5 ms frames (200 Hz frame rate).
    let d: Vec<f64> = f.windows(2).map(|w| w[1] - w[0]).collect();
    let frame = (0.005 * FS) as usize;
    let env: Vec<f64> = d.chunks(frame).map(rms).collect();
    let mean = env.iter().sum::<f64>() / env.len() as f64;
    let rate = FS / frame as f64;
    // Direct f64 DFT of the envelope on a 0.05 Hz grid over 1–30 Hz.
    let mut best = (0.0, 0.0);
    let mut k = 1.0;
    while k <= 30.0 {
        let (mut re, mut im) = (0.0, 0.0);
        for (i, e) in env.iter().enumerate() {
            let ph = std::f64::consts::TAU * k * i as f64 / rate;
            re += (e - mean) * ph.cos();
            im += (e - mean) * ph.sin();
        }
        let mag = re.hypot(im);
        if mag > best.1 {
            best = (k, mag);
        }
        k += 0.05;
    }
    eprintln!(
        "rotation rate {f_rot:.3} Hz, envelope spectrum peak at {:.3} Hz",
        best.0
    );
    assert!(
        (best.0 - f_rot).abs() < 0.3,
        "peak {} Hz vs rotation {f_rot} Hz",
        best.0
    );
}

#[test]
fn seeded_determinism_and_block_size_invariance() {
    let p = SustainedParams {
        motion: MotionKind::Scribble,
        scrape_speed_m_per_s: 0.7,
        ..scrape(0.7)
    };
    let a = render(&mut SustainedVoice::new(FS, 42), &p, 20_000, 64);
    let b = render(&mut SustainedVoice::new(FS, 42), &p, 20_000, 1000);
    let c = render(&mut SustainedVoice::new(FS, 43), &p, 20_000, 64);
    assert_eq!(a, b);
    assert_ne!(a, c);
    assert!(rms(&a) > 0.0);
}

#[test]
fn zero_speed_or_pressure_computes_nothing() {
    let mut v = SustainedVoice::new(FS, 1);
    let mut buf = [7.0f32; 256];
    assert!(!v.process(&scrape(0.0), None, &mut buf));
    assert!(!v.process(
        &SustainedParams {
            pressure_n: 0.0,
            ..scrape(1.0)
        },
        None,
        &mut buf
    ));
    assert!(!v.process(&scrape(1.0), Some(&[0.0f32; 256]), &mut buf));
    let roll0 = SustainedParams {
        kind: ContactKind::Roll,
        roll_speed_m_per_s: 0.0,
        ..Default::default()
    };
    assert!(!v.process(&roll0, None, &mut buf));
    assert_eq!(v.samples_computed(), 0);
    assert!(buf.iter().all(|&x| x == 7.0));
    // A long stroke ends and goes inactive by itself.
    let p = SustainedParams {
        motion: MotionKind::LongStroke,
        ..scrape(6.0)
    };
    let mut n = 0;
    while v.process(&p, None, &mut buf) {
        n += 1;
        assert!(n < 1_000);
    }
    let dur = motion::min_jerk_duration_s(motion::LONG_STROKE_M, 6.0);
    assert!(
        ((n * 256) as f64 / FS - dur).abs() < 256.0 / FS * 1.01,
        "{n} blocks"
    );
}

#[test]
fn finite_and_bounded_under_abuse() {
    let motions = [
        MotionKind::Manual,
        MotionKind::BackAndForth,
        MotionKind::Circular,
        MotionKind::Strokes,
        MotionKind::Scribble,
        MotionKind::LongStroke,
    ];
    // Force bound in N: vertical ≤ m·A_ref/α_min, 19.5 N for the 10 g probe and 2e7 N for the
    // heaviest ball (1000 N / g ≈ 102 kg); horizontal ≤ β1·|Ṡ|; rolling ≤ k·(1.5 R + S)^1.5·
    // (1 + λ·|ρ̇|) ≈ 6e3 N for R = 1 m at 10 m/s.
    let bound_n = 2.1e7;
    let mut worst: f64 = 0.0;
    for &fs in &[22_050.0, 44_100.0, 96_000.0, 192_000.0] {
        let n = (0.05 * fs) as usize;
        for &speed in &[0.0, 1e-3, 1.0, 10.0] {
            for &pressure in &[0.0, 1.0, 1_000.0] {
                let mut ps = Vec::new();
                for &m in &motions {
                    ps.push(SustainedParams {
                        motion: m,
                        scrape_speed_m_per_s: speed,
                        pressure_n: pressure,
                        roughness: 1.0,
                        ..Default::default()
                    });
                }
                for &r in &[1e-3, 1.0] {
                    for &e in &[0.0, 0.5] {
                        ps.push(SustainedParams {
                            kind: ContactKind::Roll,
                            roll_speed_m_per_s: speed,
                            roll_radius_m: r,
                            roll_eccentricity: e,
                            pressure_n: pressure,
                            roughness: 1.0,
                            ..Default::default()
                        });
                    }
                }
                for p in &ps {
                    let mut v = SustainedVoice::new(fs, 2);
                    let f = render(&mut v, p, n, 480);
                    for x in &f {
                        assert!(x.is_finite());
                        worst = worst.max(x.abs());
                    }
                }
            }
        }
    }
    eprintln!("largest |force| over the abuse grid: {worst:.3e} N");
    assert!(worst < bound_n, "{worst}");
    // Non-finite inputs are sanitised.
    let nan = SustainedParams {
        scrape_speed_m_per_s: f64::NAN,
        pressure_n: f64::INFINITY,
        roughness: f64::NAN,
        roll_radius_m: f64::NAN,
        ..Default::default()
    };
    let mut v = SustainedVoice::new(FS, 2);
    let mut buf = [0.0f32; 512];
    let speeds = [f32::NAN; 512];
    v.process(&nan, Some(&speeds), &mut buf);
    assert!(buf.iter().all(|x| x.is_finite()));
}
