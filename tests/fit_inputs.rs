//! Bad inputs give one-line errors, never panics.

use std::path::PathBuf;
use tactus::fit::cli::fit_file;

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
        let e = fit_file(&p).expect_err("must fail").to_string();
        assert!(e.contains(want) && !e.contains('\n'), "{}: {e}", p.display());
    }
}

#[test]
fn stereo_is_mixed_and_fitted() {
    let p = write("stereo.wav", 24, 44_100, 2, |i| ring(i / 2));
    let r = fit_file(&p).expect("stereo fits");
    assert!(r.note.contains("mono"));
    assert!(!r.modes.is_empty());
    let f = r.modes[0].freq_hz;
    assert!((f - 0.07 * 44_100.0 / std::f64::consts::TAU).abs() < 1.0, "{f}");
}
