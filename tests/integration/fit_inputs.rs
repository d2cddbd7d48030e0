//! Bad inputs give one-line errors, never panics; `tactus fit` leaves out what it cannot fit
//! and says why, and its parallel fit is deterministic.

use crate::common::pool_one_family;
use std::path::PathBuf;
use tactus::fit::error::FitError;
use tactus::fit::pool::Pooling;
use tactus::fit::recording::fit_file;
use tactus::fit::run::{expand_inputs, fit_files};
use tactus::work::Silent;

fn fit_with(
    inputs: &[std::path::PathBuf],
    material: &str,
    count: usize,
    strict: bool,
) -> anyhow::Result<tactus::fit::run::FitOutcome> {
    fit_files(inputs, &Pooling::new(material).modes(count), strict, &Silent)
}

fn write(name: &str, bits: u16, rate: u32, ch: u16, f: impl Fn(usize) -> f64) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tactus_fit_inputs_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    let spec = hound::WavSpec {
        channels: ch,
        sample_rate: rate,
        bits_per_sample: bits,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(&p, spec).unwrap();
    let full = f64::from((1i32 << (bits - 1)) - 1);
    for i in 0..(rate as usize / 2) * ch as usize {
        w.write_sample((f(i) * full) as i32).unwrap();
    }
    w.finalize().unwrap();
    p
}

fn ring(i: usize) -> f64 {
    0.5 * (-(i as f64) / 4000.0).exp() * (i as f64 * 0.07).sin()
}

#[test]
fn rejects_bad_inputs_with_one_line_errors() {
    let dir = std::env::temp_dir();
    let not_wav = dir.join(format!("tactus_not_wav_{}.wav", std::process::id()));
    std::fs::write(&not_wav, b"hello").unwrap();
    let cases = [
        (not_wav, "not a readable WAV"),
        (write("silent.wav", 16, 44_100, 1, |_| 0.0), "silent"),
        (
            write("clipped.wav", 16, 44_100, 1, |i| (3.0 * ring(i)).clamp(-1.0, 1.0)),
            "clipped",
        ),
        (write("eight.wav", 8, 44_100, 1, ring), "8-bit"),
        (write("fast.wav", 16, 384_000, 1, ring), "sample rate"),
        (write("slow.wav", 16, 8_000, 1, ring), "sample rate"),
    ];
    for (p, want) in cases {
        let err = fit_file(&p, false).expect_err("must fail");
        assert!(
            matches!(FitError::of(&err), Some(FitError::Unreadable(_))),
            "{}: {err:?}",
            p.display()
        );
        let e = err.to_string();
        assert!(e.contains(want) && !e.contains('\n'), "{}: {e}", p.display());
    }
}

#[test]
fn stereo_is_mixed_and_fitted() {
    let p = write("stereo.wav", 24, 44_100, 2, |i| ring(i / 2));
    let r = fit_file(&p, false).expect("stereo fits");
    assert!(r.note.contains("mono"));
    assert!(!r.modes.is_empty());
    let f = r.modes[0].freq_hz;
    assert!((f - 0.07 * 44_100.0 / std::f64::consts::TAU).abs() < 1.0, "{f}");
}

/// A struck-object-like recording: partials of `f0` with growing decay.
fn object(name: &str, f0: f64) -> PathBuf {
    let fs = 44_100.0;
    write(name, 16, 44_100, 1, move |i| {
        let t = i as f64 / fs;
        (0..5)
            .map(|k| {
                let f = f0 * (1.0 + 1.9 * k as f64);
                0.15 * (-(8.0 + 6.0 * k as f64) * t).exp() * (std::f64::consts::TAU * f * t + k as f64).sin()
            })
            .sum()
    })
}

/// A fresh folder holding `files` (copied in).
fn folder(tag: &str, files: &[PathBuf]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tactus_fit_folder_{tag}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for f in files {
        std::fs::copy(f, dir.join(f.file_name().unwrap())).unwrap();
    }
    dir
}

#[test]
fn a_file_that_is_not_a_recording_is_named_as_such() {
    let readme = std::env::temp_dir().join(format!("tactus_README_{}.md", std::process::id()));
    std::fs::write(&readme, "# notes\n").unwrap();
    let e = expand_inputs(std::slice::from_ref(&readme))
        .expect_err("not a recording")
        .to_string();
    assert!(
        e.contains("not a recording") && e.contains("FLAC") && e.contains("README"),
        "{e}"
    );
    let e = fit_with(&[readme], "wood", 8, false)
        .expect_err("not a recording")
        .to_string();
    assert!(e.contains("not a recording") && !e.contains("at least 2"), "{e}");
    // A recording is known by its header whatever its name.
    let flac = std::env::temp_dir().join(format!("tactus_flac_named_dat_{}.dat", std::process::id()));
    std::fs::copy(
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/cowbell.flac"),
        &flac,
    )
    .unwrap();
    assert_eq!(
        expand_inputs(std::slice::from_ref(&flac)).expect("a FLAC").0,
        [flac]
    );
}

#[test]
fn unfittable_files_are_left_out_with_their_reason_unless_strict() {
    let good = [
        object("a.wav", 220.0),
        object("b.wav", 300.0),
        object("c.wav", 410.0),
    ];
    let silent = write("silent_in_folder.wav", 16, 44_100, 1, |_| 0.0);
    let mut all = good.to_vec();
    all.push(silent);
    let dir = folder("mixed", &all);
    std::fs::write(dir.join("notes.txt"), "not audio").unwrap();
    let out = fit_with(std::slice::from_ref(&dir), "wood", 8, false).expect("fits without the silent file");
    assert_eq!(out.results.len(), 3);
    assert_eq!(out.left_out.len(), 1, "{:?}", out.left_out);
    assert_eq!(out.left_out[0].name, "silent_in_folder.wav");
    assert!(out.left_out[0].reason.contains("silent"), "{:?}", out.left_out);
    assert!(
        out.notes
            .iter()
            .any(|n| n.contains("notes.txt") && n.contains("not recordings")),
        "{:?}",
        out.notes
    );
    let e = fit_with(&[dir], "wood", 8, true).expect_err("strict").to_string();
    assert!(
        e.contains("silent_in_folder.wav") && e.contains("--strict"),
        "{e}"
    );
    // Nothing left: the reasons are in the error.
    let dir = folder("none_good", &[all[3].clone()]);
    let e = fit_with(&[dir], "wood", 8, false)
        .expect_err("no fittable file")
        .to_string();
    assert!(
        e.contains("no recording could be fitted") && e.contains("silent_in_folder.wav: "),
        "{e}"
    );
}

#[test]
fn parallel_fit_equals_sequential_fit_byte_for_byte() {
    let files: Vec<PathBuf> = (0..5)
        .map(|i| object(&format!("det_{i}.wav"), 180.0 + 70.0 * i as f64))
        .collect();
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| fit_with(&files, "metal", 8, true).expect("fit").preset.to_json())
    };
    let one = run(1);
    assert_eq!(one, run(3));
    // And equal to fitting the files one by one.
    let seq: Vec<_> = files.iter().map(|f| fit_file(f, false).unwrap()).collect();
    assert_eq!(one, pool_one_family("metal", &seq, 8).unwrap().to_json());
}
