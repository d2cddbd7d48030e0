//! The `tactus` binary says what it does: each bad input is one line on stderr and a non-zero
//! exit, the bench writes where it says, WAV files open in the readers the README names.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn tactus() -> Command {
    Command::new(env!("CARGO_BIN_EXE_tactus"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tactus-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Renders `scene` (JSON text) and returns the process output.
fn render_scene(dir: &Path, scene: &str, extra: &[&str]) -> Output {
    let path = dir.join("scene.json");
    std::fs::write(&path, scene).unwrap();
    tactus()
        .arg("render")
        .arg(&path)
        .arg("-o")
        .arg(dir.join("out.wav"))
        .args(extra)
        .output()
        .unwrap()
}

/// Asserts a failed run with exactly one stderr line containing every `needle`.
fn assert_one_line_error(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "expected failure, got success; stderr: {err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks '{n}': {err}");
    }
}

#[test]
fn out_of_range_settings_are_errors_naming_field_value_and_range() {
    let d = tmp("settings");
    for (field, value, range) in [
        ("damping", "-1", "0..=100"),
        ("mass_kg", "-1", "0.000001..=1000 kg"),
        ("gain_db", "100", "-120..=24 dB"),
        ("size", "0", "0.01..=100"),
        ("quality_db", "0.5", "1..=300 dB"),
        ("variation", "3", "0..=2"),
        ("hardness", "20000", "0.0001..=10000"),
    ] {
        let scene = format!(
            r#"{{"duration_s": 0.2, "material": "wood", "settings": {{"{field}": {value}}},
                "events": [{{"type": "impact", "time_s": 0.01}}]}}"#
        );
        let out = render_scene(&d, &scene, &[]);
        assert_one_line_error(
            &out,
            &[&format!("settings.{field}"), range, &format!("got {value}")],
        );
    }
    // The same in an object's own settings.
    let scene = r#"{"duration_s": 0.2, "objects": {"cup": {"material": "glass", "settings": {"damping": -1}}},
        "events": [{"type": "impact", "object": "cup", "time_s": 0.01}]}"#;
    assert_one_line_error(
        &render_scene(&d, scene, &[]),
        &["objects.cup.settings.damping", "got -1"],
    );
}

#[test]
fn events_at_or_after_the_end_are_errors() {
    let d = tmp("late");
    for (ev, t) in [
        (r#"{"type": "impact", "time_s": 1.5}"#, "1.5"),
        (r#"{"type": "impact", "time_s": 1.0}"#, "1"),
        (r#"{"type": "new_object", "time_s": 2, "seed": 3}"#, "2"),
        (
            r#"{"type": "scrape", "time_s": 1.2, "duration_s": 0.5, "speed_m_per_s": 0.3}"#,
            "1.2",
        ),
    ] {
        let scene = format!(r#"{{"duration_s": 1.0, "material": "wood", "events": [{ev}]}}"#);
        assert_one_line_error(
            &render_scene(&d, &scene, &[]),
            &[&format!("events[0].time_s {t} s"), "duration_s 1 s"],
        );
    }
}

#[test]
fn unknown_fields_and_bad_objects_are_errors() {
    let d = tmp("unknown");
    let cases = [
        (
            r#"{"duration_s": 1, "material": "wood", "setings": {}}"#,
            "unknown field `setings`",
        ),
        (
            r#"{"duration_s": 1, "material": "wood", "settings": {"dampng": 1}}"#,
            "unknown field `dampng`",
        ),
        (
            r#"{"duration_s": 1, "material": "wood", "events": [{"type": "impact", "time_s": 0, "velocity": 1}]}"#,
            "unknown field `velocity`",
        ),
        (
            r#"{"duration_s": 1, "objects": {"a": {"material": "wood", "sede": 1}}}"#,
            "unknown field `sede`",
        ),
        (r#"{"duration_s": 1}"#, "missing `material`"),
        (
            r#"{"duration_s": 1, "material": "wood", "objects": {"a": {"material": "wood"}}}"#,
            "not both",
        ),
        (
            r#"{"duration_s": 1, "objects": {"a": {"material": "wood"}}, "events": [{"type": "impact", "time_s": 0}]}"#,
            "events[0] needs an \"object\" (one of: a)",
        ),
        (
            r#"{"duration_s": 1, "objects": {"a": {"material": "wood"}}, "events": [{"type": "impact", "object": "b", "time_s": 0}]}"#,
            "events[0].object 'b' is not in `objects`",
        ),
        (
            r#"{"duration_s": 1, "material": "wood", "events": [{"type": "impact", "object": "a", "time_s": 0}]}"#,
            "the scene has no `objects`",
        ),
        (
            r#"{"duration_s": 1, "objects": {"a/b": {"material": "wood"}}}"#,
            "object name 'a/b'",
        ),
    ];
    for (scene, needle) in cases {
        assert_one_line_error(&render_scene(&d, scene, &[]), &[needle]);
    }
}

#[test]
fn bad_block_sizes_are_errors() {
    let d = tmp("block");
    let scene = r#"{"duration_s": 0.1, "material": "wood"}"#;
    for b in ["0", "8193"] {
        assert_one_line_error(
            &render_scene(&d, scene, &["--block", b]),
            &["--block must be in 1..=8192", b],
        );
    }
}

#[test]
fn preset_errors_name_the_problem_once() {
    let d = tmp("preset");
    let missing = r#"{"duration_s": 0.1, "material": {"preset_file": "nope.json"}}"#;
    let out = render_scene(&d, missing, &[]);
    assert_one_line_error(&out, &["nope.json", "cannot read"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("(file)") && !err.contains("field `"), "{err}");

    std::fs::write(d.join("broken.json"), "{\"name\": \"x\",").unwrap();
    let broken = r#"{"duration_s": 0.1, "material": {"preset_file": "broken.json"}}"#;
    let out = render_scene(&d, broken, &[]);
    assert_one_line_error(&out, &["broken.json", "not valid JSON", "line 1 column"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("(json)") && err.matches("line").count() == 1,
        "{err}"
    );

    std::fs::write(d.join("other.json"), r#"{"name": "x"}"#).unwrap();
    let other = r#"{"duration_s": 0.1, "material": {"preset_file": "other.json"}}"#;
    assert_one_line_error(
        &render_scene(&d, other, &[]),
        &["other.json", "not a Tactus preset", "missing field"],
    );
}

/// `tactus preset worst-case` writes the very presets the unit tests' real-time checks use, so the
/// host tests (tests/host/rt_child.py) that load its file cannot drift to a lighter case.
#[test]
fn preset_worst_case_writes_the_library_worst_cases() {
    use tactus::preset::{worst_case_build_up_preset, worst_case_preset, worst_case_ring_preset, Preset};
    let d = tmp("worst-case");
    for (kind, want) in [
        ("plain", worst_case_preset()),
        ("build-up", worst_case_build_up_preset()),
        ("ring", worst_case_ring_preset()),
    ] {
        let path = d.join(format!("{kind}.json"));
        let out = tactus()
            .args(["preset", "worst-case", "--kind", kind, "-o"])
            .arg(&path)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let got = Preset::load(&path).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert_eq!(got.to_json(), want.to_json(), "{kind}");
    }
    let out = tactus()
        .args(["preset", "worst-case", "-o"])
        .arg(d.join("no-such-dir/w.json"))
        .output()
        .unwrap();
    assert_one_line_error(&out, &["no-such-dir/w.json", "cannot write"]);
}

/// A file's samples (any format hound reads) as f32.
fn samples(path: &Path) -> (hound::WavSpec, Vec<f32>) {
    let mut r = hound::WavReader::open(path).unwrap();
    let spec = r.spec();
    let v = match spec.sample_format {
        hound::SampleFormat::Float => r.samples::<f32>().map(Result::unwrap).collect(),
        hound::SampleFormat::Int => r.samples::<i32>().map(|s| s.unwrap() as f32).collect(),
    };
    (spec, v)
}

#[test]
fn default_wav_header_is_plain_pcm_that_python_wave_opens() {
    let d = tmp("wav");
    let scene =
        r#"{"duration_s": 0.25, "material": "metal", "events": [{"type": "impact", "time_s": 0.01}]}"#;
    std::fs::write(d.join("s.json"), scene).unwrap();
    for (header, file) in [("plain", "plain.wav"), ("extensible", "ext.wav")] {
        let out = tactus()
            .args(["render"])
            .arg(d.join("s.json"))
            .arg("-o")
            .arg(d.join(file))
            .args(["--wav-header", header])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let default = d.join("default.wav");
    let out = tactus()
        .arg("render")
        .arg(d.join("s.json"))
        .arg("-o")
        .arg(&default)
        .output()
        .unwrap();
    assert!(out.status.success());
    let plain = std::fs::read(d.join("plain.wav")).unwrap();
    assert_eq!(
        std::fs::read(&default).unwrap(),
        plain,
        "default header is not plain"
    );
    // Format tag 1 (PCM) in a 16-byte fmt chunk; extensible is tag 0xFFFE.
    assert_eq!(&plain[20..22], &[1, 0]);
    assert_eq!(&plain[16..20], &16u32.to_le_bytes());
    let ext = std::fs::read(d.join("ext.wav")).unwrap();
    assert_eq!(&ext[20..22], &[0xfe, 0xff]);
    // Same samples either way.
    let (sp, a) = samples(&d.join("plain.wav"));
    let (se, b) = samples(&d.join("ext.wav"));
    assert_eq!((sp.bits_per_sample, sp.channels, sp.sample_rate), (24, 2, 48_000));
    assert_eq!((se.bits_per_sample, se.channels), (24, 2));
    assert_eq!(a, b);
    assert!(a.iter().any(|v| *v != 0.0));

    let py = "import sys, wave\nw = wave.open(sys.argv[1])\nprint(w.getnchannels(), w.getsampwidth(), w.getframerate(), w.getnframes())";
    match Command::new("python3")
        .arg("-c")
        .arg(py)
        .arg(d.join("plain.wav"))
        .output()
    {
        Ok(o) => {
            assert!(
                o.status.success(),
                "python wave failed: {}",
                String::from_utf8_lossy(&o.stderr)
            );
            assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "2 3 48000 12000");
        }
        Err(e) => eprintln!("SKIPPED python3 check: {e}"),
    }
}

#[test]
fn float32_and_pcm16_plain_files_read_back() {
    let d = tmp("formats");
    let scene = r#"{"duration_s": 0.1, "material": "glass", "events": [{"type": "impact", "time_s": 0.0}]}"#;
    std::fs::write(d.join("s.json"), scene).unwrap();
    for (fmt, bits, tag) in [("float32", 32, 3u8), ("pcm16", 16, 1)] {
        let f = d.join(format!("{fmt}.wav"));
        let out = tactus()
            .arg("render")
            .arg(d.join("s.json"))
            .arg("-o")
            .arg(&f)
            .args(["--format", fmt])
            .output()
            .unwrap();
        assert!(out.status.success());
        assert_eq!(std::fs::read(&f).unwrap()[20], tag);
        let (spec, v) = samples(&f);
        assert_eq!(spec.bits_per_sample, bits);
        assert_eq!(v.len(), 2 * 4800);
    }
}

#[test]
fn stems_are_the_objects_and_sum_to_the_mix() {
    let d = tmp("stems");
    let scene = r#"{"duration_s": 0.5, "seed": 4,
        "settings": {"gain_db": -6, "width": 0.5},
        "objects": {
            "pan": {"material": "metal", "seed": 11},
            "board": {"material": "wood", "settings": {"size": 0.5}}
        },
        "events": [
            {"type": "impact", "object": "pan", "time_s": 0.01},
            {"type": "impact", "object": "board", "time_s": 0.1, "velocity_m_per_s": 2},
            {"type": "scrape", "object": "board", "time_s": 0.2, "duration_s": 0.2, "speed_m_per_s": 0.4}
        ]}"#;
    std::fs::write(d.join("s.json"), scene).unwrap();
    let out = tactus()
        .arg("render")
        .arg(d.join("s.json"))
        .arg("-o")
        .arg(d.join("mix.wav"))
        .args(["--format", "float32", "--stems"])
        .arg(d.join("stems"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (_, mix) = samples(&d.join("mix.wav"));
    let (_, board) = samples(&d.join("stems/board.wav"));
    let (_, pan) = samples(&d.join("stems/pan.wav"));
    // Objects mix in name order: board first, then pan added.
    let sum: Vec<f32> = board.iter().zip(&pan).map(|(a, b)| a + b).collect();
    assert_eq!(mix, sum);
    assert!(board.iter().any(|v| *v != 0.0) && pan.iter().any(|v| *v != 0.0));
    // Stems stay stereo: at width 0.5 each has its own left and right.
    for stem in [&board, &pan] {
        assert!(stem.chunks(2).any(|lr| lr[0] != lr[1]), "a stem is mono");
    }

    // Each stem is that object alone as a one-object scene (its seed, merged settings, events).
    let alone = r#"{"duration_s": 0.5, "seed": 4, "material": "wood",
        "settings": {"gain_db": -6, "size": 0.5, "width": 0.5},
        "events": [
            {"type": "impact", "time_s": 0.1, "velocity_m_per_s": 2},
            {"type": "scrape", "time_s": 0.2, "duration_s": 0.2, "speed_m_per_s": 0.4}
        ]}"#;
    let out = render_scene(&d, alone, &["--format", "float32"]);
    assert!(out.status.success());
    assert_eq!(samples(&d.join("out.wav")).1, board);
    let alone = r#"{"duration_s": 0.5, "seed": 11, "material": "metal", "settings": {"gain_db": -6, "width": 0.5},
        "events": [{"type": "impact", "time_s": 0.01}]}"#;
    let out = render_scene(&d, alone, &["--format", "float32"]);
    assert!(out.status.success());
    assert_eq!(samples(&d.join("out.wav")).1, pan);
}

#[test]
fn bench_writes_under_target_unless_told_to_update_docs() {
    // Run in a scratch folder that has its own docs/bench/results.md: `bench --quick` must leave
    // it alone and write target/bench/.
    let d = tmp("bench");
    std::fs::create_dir_all(d.join("docs/bench")).unwrap();
    std::fs::write(d.join("docs/bench/results.md"), "committed\n").unwrap();
    let out = tactus()
        .args(["bench", "--quick"])
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(
        std::fs::read_to_string(d.join("docs/bench/results.md")).unwrap(),
        "committed\n"
    );
    assert!(!d.join("docs/bench/time_vs_error.svg").exists());
    assert!(d.join("target/bench/results.md").exists());
    assert!(d.join("target/bench/time_vs_error.svg").exists());
    // --update-docs and --out together are refused.
    let out = tactus()
        .args(["bench", "--quick", "--update-docs", "--out", "x"])
        .current_dir(&d)
        .output()
        .unwrap();
    assert!(!out.status.success());
}

/// `bench --kernel` runs the variant it names and says so in the report's header; one this CPU
/// lacks is refused with a line naming it.
#[test]
fn bench_runs_the_kernel_it_is_given() {
    use tactus::engine::modal::Kernel;
    let bench = |kernel: &str| {
        tactus()
            .args([
                "bench",
                "--quick",
                "--only",
                "single impact (wood)",
                "--kernel",
                kernel,
            ])
            .output()
            .unwrap()
    };
    let out = bench("portable");
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains("- Kernel auto-detected: Portable"), "{text}");
    let best = Kernel::best();
    if best != Kernel::Portable {
        assert!(text.contains(&format!("this CPU's best is {best:?}")), "{text}");
    }
    for (arg, kernel) in [("avx2", Kernel::Avx2), ("avx512", Kernel::Avx512)] {
        if !kernel.is_supported() {
            assert_one_line_error(
                &bench(arg),
                &["--kernel", &format!("{kernel:?}"), "does not support"],
            );
        }
    }
}

#[test]
fn help_describes_the_commands() {
    let out = tactus().arg("--help").output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    for cmd in ["render", "batch", "merge-manifests", "fit", "bench", "preset"] {
        assert!(help.contains(cmd), "--help lacks {cmd}: {help}");
    }
    // The formats the one reader of recordings reads, in the help of each command reading them
    // and in the README's fit section.
    let formats = tactus::analysis::audio::FORMATS;
    assert!(help.contains(formats), "--help lacks {formats}: {help}");
    for cmd in ["fit", "eval"] {
        let out = tactus().args([cmd, "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&out.stdout);
        assert!(help.contains(formats), "{cmd} --help lacks {formats}: {help}");
    }
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/README.md")).unwrap();
    let fit_section = &readme[readme.find("Fit your own").expect("README: fit section")..];
    assert!(
        fit_section[..1500].contains(formats),
        "README's fit section lacks {formats}"
    );
    let out = tactus().args(["render", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("at most 1e-5 of full scale"), "{help}");
    assert!(!help.contains("does not depend on it"), "{help}");
}

#[test]
fn eval_dense_needs_a_leave_one_out_mode() {
    // `--dense` changes only how a held-out material is fitted; on preset judging it would be
    // silently meaningless, so it is refused before anything is measured.
    let out = tactus()
        .args(["eval", "no-such-folder", "--dense"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("--leave-family-out"), "{err}");
    assert!(err.contains("--leave-kit-out"), "{err}");
    // With either leave-one-out mode it is accepted, and the folder is what is refused.
    let out = tactus()
        .args([
            "eval",
            "no-such-folder",
            "--leave-kit-out",
            "ride cymbal",
            "--dense",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("no-such-folder: not a folder of recordings"),
        "{err}"
    );
    let out = tactus()
        .args([
            "eval",
            "x",
            "--leave-kit-out",
            "ride",
            "--leave-family-out",
            "metal",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot be used with"), "{err}");
    let out = tactus().args(["eval", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("--dense"), "{help}");
    assert!(help.contains("--leave-kit-out"), "{help}");
}

#[test]
fn eval_components_refuses_what_it_cannot_judge() {
    // A preset without mixture components has nothing to judge against its own recordings.
    let dir = tmp("components");
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: 44_100,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(dir.join("wood_claves_x.wav"), spec).unwrap();
    for i in 0..22_050 {
        let t = i as f64 / 44_100.0;
        let v = (std::f64::consts::TAU * 2500.0 * t).sin() * (-60.0 * t).exp();
        w.write_sample((v * 20_000.0) as i16).unwrap();
    }
    w.finalize().unwrap();
    let out = tactus()
        .arg("eval")
        .arg(&dir)
        .args(["--components", "--preset", "Glass", "--draws", "1"])
        .output()
        .unwrap();
    assert_one_line_error(
        &out,
        &[
            "no component of Glass names a recording",
            &dir.display().to_string(),
        ],
    );
    // It judges presets, not a held-out material.
    let out = tactus()
        .args(["eval", "x", "--components", "--leave-kit-out", "ride"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("cannot be used with"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `render --limit` passes the mix through the plugin's output limiter: a render far above full
/// scale comes out at or under the ceiling, a quiet one bit-identical; without it the float
/// render keeps its peaks.
#[test]
fn render_limit_caps_the_mix_and_leaves_quiet_renders_alone() {
    use tactus::engine::limiter::CEILING;
    let d = tmp("limit");
    let peak = |v: &[f32]| v.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let scene = |gain_db: i32| {
        format!(
            r#"{{"duration_s": 0.3, "material": "glass", "settings": {{"gain_db": {gain_db}}},
                "events": [{{"type": "impact", "time_s": 0.01, "velocity_m_per_s": 10}}]}}"#
        )
    };
    let render = |gain_db: i32, limit: bool| {
        let extra: &[&str] = if limit {
            &["--format", "float32", "--limit"]
        } else {
            &["--format", "float32"]
        };
        let out = render_scene(&d, &scene(gain_db), extra);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        samples(&d.join("out.wav")).1
    };
    let (loud, limited) = (render(24, false), render(24, true));
    assert!(
        peak(&loud) > 2.0,
        "the test needs a render above full scale: {}",
        peak(&loud)
    );
    assert!(peak(&limited) <= CEILING, "{}", peak(&limited));
    let (quiet, quiet_limited) = (render(-30, false), render(-30, true));
    assert!(
        peak(&quiet) > 0.0 && peak(&quiet) <= CEILING / 2.0,
        "{}",
        peak(&quiet)
    );
    assert_eq!(quiet, quiet_limited);
}
