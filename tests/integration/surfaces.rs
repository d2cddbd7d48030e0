//! Measured surfaces (src/engine/sustained/measured.rs, src/analysis/surfaces.rs): the endless
//! synthesised profiles keep each scan's statistics, a long scrape never repeats the scan, bad
//! inputs are refused by name.

use std::path::PathBuf;
use tactus::analysis::surfaces::{self, octave_db, octave_db_of, read_profile, SCAN_LENGTH_M};
use tactus::engine::sustained::measured::{band_powers, table_cdf, SurfaceKind, SPACING_M};
use tactus::engine::sustained::{ContactKind, MotionKind, SustainedParams, SustainedVoice};

/// Every measured surface, synthesised for seeds the calibration did not use: its octave-band
/// height spectrum within ±1 dB of the measured one and its heights' distribution within a
/// Kolmogorov–Smirnov distance of 0.05 of the measured quantile table.
#[test]
fn synthesised_surfaces_keep_the_measured_statistics() {
    let mut worst = (0.0f64, 0.0f64);
    for kind in &SurfaceKind::ALL[1..] {
        let stats = kind.stats().expect("measured");
        for seed in [11u64, 12] {
            let h = surfaces::synthesise(stats, seed, 1 << 19);
            let got = octave_db(&band_powers(&h, SPACING_M));
            let want = octave_db_of(&stats.band_db);
            for (o, (g, w)) in got.iter().zip(&want).enumerate() {
                let d = g - w;
                worst.0 = worst.0.max(d.abs());
                assert!(
                    d.abs() <= 1.0,
                    "{} seed {seed} octave {o}: {g:.2} vs {w:.2} dB",
                    kind.name()
                );
            }
            let mut sorted: Vec<f64> = h.iter().map(|v| v / stats.rms_m).collect();
            sorted.sort_by(f64::total_cmp);
            let n = sorted.len() as f64;
            let ks = sorted
                .iter()
                .enumerate()
                .map(|(i, &v)| {
                    let f = table_cdf(&stats.quantiles, v);
                    (f - i as f64 / n).abs().max((f - (i + 1) as f64 / n).abs())
                })
                .fold(0.0, f64::max);
            worst.1 = worst.1.max(ks);
            assert!(ks < 0.05, "{} seed {seed}: KS distance {ks:.3}", kind.name());
        }
    }
    eprintln!(
        "worst octave-band error {:.2} dB, worst KS distance {:.3}",
        worst.0, worst.1
    );
}

/// Envelope (RMS per 10 ms frame) of `x`, mean removed, and its normalised autocorrelation at
/// `lag` frames.
fn envelope_acf(env: &[f64], lag: usize) -> f64 {
    let m = env.iter().sum::<f64>() / env.len() as f64;
    let e: Vec<f64> = env.iter().map(|v| v - m).collect();
    let var: f64 = e.iter().map(|v| v * v).sum();
    let c: f64 = e.iter().zip(&e[lag..]).map(|(a, b)| a * b).sum();
    c / var
}

fn envelope(x: &[f64], frame: usize) -> Vec<f64> {
    x.chunks_exact(frame)
        .map(|c| (c.iter().map(|v| v * v).sum::<f64>() / frame as f64).sqrt())
        .collect()
}

/// A 60 s scrape at 0.5 m/s on a measured surface travels 30 m, 213 scan lengths: its force
/// envelope has no autocorrelation peak at the scan's period (or its multiples), where a looped
/// scan's is near 1 (checked on the same force looped, so the measure can fail).
#[test]
fn a_long_scrape_never_repeats_the_scan() {
    let fs = 48_000.0;
    let speed = 0.5;
    let p = SustainedParams {
        kind: ContactKind::Scrape,
        motion: MotionKind::Manual,
        scrape_speed_m_per_s: speed,
        pressure_n: 5.0,
        surface: SurfaceKind::Pvc,
        ..Default::default()
    };
    let mut v = SustainedVoice::new(fs, 5);
    let n = (60.0 * fs) as usize;
    let mut force = Vec::with_capacity(n);
    let mut buf = vec![0.0f32; 512];
    while force.len() < n {
        assert!(v.process(&p, None, &mut buf));
        force.extend(buf.iter().map(|&x| x as f64));
    }
    assert!(force.iter().all(|x| x.is_finite()));
    let frame = 480;
    let env = envelope(&force, frame);
    let period_frames = SCAN_LENGTH_M / speed * fs / frame as f64;
    let peak_near = |env: &[f64], k: f64| {
        let c = (k * period_frames).round() as usize;
        let r = (0.03 * c as f64).ceil() as usize;
        (c - r..=c + r)
            .map(|l| envelope_acf(env, l))
            .fold(f64::MIN, f64::max)
    };
    let worst = (1..=10)
        .map(|k| peak_near(&env, k as f64))
        .fold(f64::MIN, f64::max);
    // The control: the first scan length of the same force (to a whole frame), looped for the
    // same 60 s.
    let period = period_frames.round() as usize * frame;
    let looped: Vec<f64> = (0..n).map(|i| force[i % period]).collect();
    let looped_env = envelope(&looped, frame);
    let control = peak_near(&looped_env, 1.0);
    eprintln!("envelope autocorrelation at 1–10 scan periods: max {worst:.3}; looped control {control:.3}");
    assert!(
        control > 0.9,
        "the looped control must show its period: {control}"
    );
    assert!(worst < 0.15, "repetition at the scan period: {worst}");
}

fn write_npy(path: &std::path::Path, descr: &str, shape: &str, payload: &[u8]) {
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape}, }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    bytes.extend_from_slice(payload);
    std::fs::write(path, bytes).unwrap();
}

/// The reader takes a 1-D float array and refuses anything else with an error naming the file
/// and what it found.
#[test]
fn the_reader_refuses_what_is_not_a_1d_float_array() {
    let dir = std::env::temp_dir().join(format!("tactus-surfaces-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let floats: Vec<u8> = (0..2000).flat_map(|i| (i as f64 * 1e-9).to_le_bytes()).collect();
    let ok = dir.join("ok.npy");
    write_npy(&ok, "<f8", "(2000,)", &floats);
    assert_eq!(read_profile(&ok).unwrap().len(), 2000);
    let two_d = dir.join("two_d.npy");
    write_npy(&two_d, "<f8", "(1000, 2)", &floats);
    let ints = dir.join("ints.npy");
    let int_bytes: Vec<u8> = (0..2000i32).flat_map(|i| i.to_le_bytes()).collect();
    write_npy(&ints, "<i4", "(2000,)", &int_bytes);
    let text = dir.join("text.npy");
    std::fs::write(&text, "0.1 0.2 0.3\n").unwrap();
    for (path, what) in [
        (&two_d, "shape [1000, 2]"),
        (&ints, "dtype <i4"),
        (&text, "not a NumPy .npy file"),
    ] {
        let e = format!("{:#}", read_profile(path).unwrap_err());
        assert!(e.contains(&path.display().to_string()), "{e}");
        assert!(e.contains(what), "{e}");
        assert!(!e.contains('\n'), "one line: {e}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene naming an unknown surface is refused with the name in the message.
#[test]
fn a_scene_with_an_unknown_surface_names_it() {
    let scene = r#"{"duration_s": 1, "material": "wood", "events": [
        {"type": "scrape", "time_s": 0, "duration_s": 0.5, "speed_m_per_s": 0.3, "surface": "velvet"}]}"#;
    let e = format!("{:#}", tactus::scene::Scene::parse(scene, None).unwrap_err());
    assert!(e.contains("velvet"), "{e}");
    let ok = scene.replace("velvet", "sandpaper");
    tactus::scene::Scene::parse(&ok, None).expect("a measured surface is a valid scene value");
}

/// The committed statistics are what `tactus surfaces derive` gives for the scans (when the
/// scans are here): the shipped file is not stale.
#[test]
fn committed_statistics_match_the_scans() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/measured/surfaces");
    if !dir.is_dir() {
        eprintln!("SKIPPED: {} not found", dir.display());
        return;
    }
    for kind in [SurfaceKind::Acrylic, SurfaceKind::SandedAcrylic] {
        let d = surfaces::derive_one(kind, &dir.join(format!("{}.npy", kind.name()))).unwrap();
        let shipped = kind.stats().unwrap();
        assert!(
            (d.stats.rms_m / shipped.rms_m - 1.0).abs() < 1e-4,
            "{}",
            kind.name()
        );
        for (a, b) in d.stats.band_db.iter().zip(&shipped.band_db) {
            assert!((a - b).abs() < 0.01, "{}: {a} vs {b}", kind.name());
        }
        for (a, b) in d.stats.quantiles.iter().zip(&shipped.quantiles) {
            assert!((a - b).abs() < 1e-4, "{}: {a} vs {b}", kind.name());
        }
    }
}

/// Selecting a measured surface, switching between surfaces and travelling over new ground
/// (new stretches synthesised) allocate nothing: it all runs in the voice's preallocated slots.
#[test]
fn measured_surfaces_never_allocate_while_processing() {
    use crate::counting_alloc::allocs;
    let mut v = SustainedVoice::new(48_000.0, 9);
    let mut buf = vec![0.0f32; 256];
    let mut p = SustainedParams {
        kind: ContactKind::Scrape,
        motion: MotionKind::Circular,
        scrape_speed_m_per_s: 3.0,
        pressure_n: 5.0,
        ..Default::default()
    };
    let before = allocs();
    let made = v.measured().stretches_made();
    for (i, kind) in SurfaceKind::ALL.iter().cycle().take(40).enumerate() {
        p.surface = *kind;
        p.kind = if i % 2 == 0 {
            ContactKind::Scrape
        } else {
            ContactKind::Roll
        };
        p.roll_speed_m_per_s = 3.0;
        for _ in 0..20 {
            v.process(&p, None, &mut buf);
        }
        assert!(buf.iter().all(|x| x.is_finite()));
    }
    assert_eq!(allocs() - before, 0, "allocations while processing");
    assert!(
        v.measured().stretches_made() > made + 100,
        "new ground was synthesised"
    );
}

/// Scrapes at one speed and pressure on the same object, one per seed on each measured surface:
/// a nearest-centre classifier (band levels and kurtosis, each scrape left out of its own
/// training) tells apart at least 80 % of the time every pair of surfaces whose measured
/// octave-band height spectra differ by more than 3 dB somewhere audible at that speed. Prints
/// the 12 × 12 confusion matrix and every pair (docs/measured.md).
#[test]
fn scrapes_on_distinct_surfaces_are_told_apart() {
    use tactus::eval::surface_id::{recognise, DISTINCT_DB, SPEED_M_PER_S};
    let r = recognise(SCRAPES_PER_SURFACE);
    eprintln!(
        "12-way, each scrape left out: {:.1} % ({} of {}); {SCRAPES_PER_SURFACE} scrapes per surface at {SPEED_M_PER_S} m/s",
        100.0 * r.confusion.share(),
        r.confusion.correct(),
        r.confusion.total()
    );
    eprintln!("{}", r.confusion.markdown(short_surface));
    let mut bad = Vec::new();
    for p in &r.pairs {
        let expected = p.difference_db > DISTINCT_DB;
        eprintln!(
            "{:>15} / {:<15} spectra differ by {:5.1} dB: told apart {:5.1} %{}",
            p.a.name(),
            p.b.name(),
            p.difference_db,
            100.0 * p.share,
            if expected { "" } else { " (not required)" }
        );
        if expected && p.share < 0.8 {
            bad.push(format!(
                "{} / {}: {:.0} %",
                p.a.name(),
                p.b.name(),
                100.0 * p.share
            ));
        }
    }
    assert!(bad.is_empty(), "pairs told apart < 80 %: {}", bad.join(", "));
}

/// Scrapes per surface: enough that one scrape left out barely moves its surface's centre.
const SCRAPES_PER_SURFACE: usize = 12;

/// Column heads of the surface matrix.
fn short_surface(name: &str) -> String {
    match name {
        "acrylic" => "acr",
        "bass_wood" => "bass",
        "ceramic" => "cer",
        "plywood" => "ply",
        "polycarbonate" => "pc",
        "polyethylene" => "pe",
        "poplar_wood" => "pop",
        "pvc" => "pvc",
        "rough_wood" => "rough",
        "sanded_acrylic" => "sand-acr",
        "sandpaper" => "paper",
        "vinyl" => "vinyl",
        other => other,
    }
    .to_owned()
}
