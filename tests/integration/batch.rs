//! `tactus batch` end to end through the binary: shards, resuming after a kill, re-rendering a
//! manifest row, refusing a folder of another batch, spec errors.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn tactus() -> Command {
    Command::new(env!("CARGO_BIN_EXE_tactus"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tactus-batch-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A spec of `samples` × 2 materials × 2 seeds items of `dur_s` each, in `dir`.
fn write_spec(dir: &Path, samples: usize, dur_s: f64) -> PathBuf {
    std::fs::write(
        dir.join("base.json"),
        format!(
            r#"{{"duration_s": {dur_s}, "material": "wood", "settings": {{"gain_db": -6}},
               "events": [{{"type": "impact", "time_s": 0.01}},
                          {{"type": "impact", "time_s": {t2}, "pitch": 1.5}}]}}"#,
            t2 = dur_s / 2.0
        ),
    )
    .unwrap();
    let spec = dir.join("spec.json");
    std::fs::write(
        &spec,
        format!(
            r#"{{"scene": "base.json", "samples": {samples}, "seed": 9, "params": [
                {{"path": "/material", "grid": ["wood", "glass"]}},
                {{"path": "/seed", "int_range": [3, 4]}},
                {{"path": "/settings/damping", "log_uniform": [0.5, 2.0]}},
                {{"path": "/settings/size", "uniform": [0.6, 1.4]}},
                {{"path": "/events/0/velocity_m_per_s", "uniform": [0.3, 2.0]}}]}}"#
        ),
    )
    .unwrap();
    spec
}

fn batch(args: &[&str], spec: &Path, out: &Path) -> std::process::Output {
    let o = tactus()
        .arg("batch")
        .arg(spec)
        .arg("-o")
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "batch {args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

/// Every file of a folder (not hidden), name → bytes, sorted.
fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

fn wavs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    files(dir)
        .into_iter()
        .filter(|(n, _)| n.ends_with(".wav"))
        .collect()
}

#[test]
fn two_shards_merged_are_byte_identical_to_one_run() {
    let d = tmp("shards");
    let spec = write_spec(&d, 3, 0.3);
    let whole = d.join("whole");
    batch(&["--threads", "2"], &spec, &whole);
    let sharded = d.join("sharded");
    batch(&["--shard", "1/2", "--threads", "1"], &spec, &sharded);
    batch(&["--shard", "0/2"], &spec, &sharded);
    let o = tactus().arg("merge-manifests").arg(&sharded).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let a = files(&whole);
    let b: Vec<_> = files(&sharded)
        .into_iter()
        .filter(|(n, _)| !n.starts_with("manifest-shard-"))
        .collect();
    assert_eq!(wavs(&whole).len(), 12);
    assert_eq!(
        a.iter().map(|x| &x.0).collect::<Vec<_>>(),
        b.iter().map(|x| &x.0).collect::<Vec<_>>()
    );
    for ((n, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{n} differs between the whole run and the merged shards");
    }
    // The manifest has every item once, in order, with distinct sampled values.
    let jsonl = std::fs::read_to_string(whole.join("manifest.jsonl")).unwrap();
    let rows: Vec<serde_json::Value> = jsonl.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(rows.len(), 12);
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(r["index"], i);
        assert_eq!(r["file"], format!("{i:06}.wav"));
        assert!(r["peak"].as_f64().unwrap() > 1e-3, "row {i} silent");
        assert!(r["rms"].as_f64().unwrap() > 0.0);
        assert_eq!(r["duration_s"], 0.3);
        let damping = r["params"]["/settings/damping"].as_f64().unwrap();
        assert!((0.5..=2.0).contains(&damping));
        assert_eq!(r["scene"]["settings"]["damping"].as_f64().unwrap(), damping);
    }
    // Grid order: material slowest, then seed, then the samples.
    assert_eq!(rows[0]["params"]["/material"], "wood");
    assert_eq!(rows[6]["params"]["/material"], "glass");
    assert_eq!(rows[3]["seed"], 4);
    let csv = std::fs::read_to_string(whole.join("manifest.csv")).unwrap();
    assert!(csv.starts_with(
        "file,index,seed,/material,/seed,/settings/damping,/settings/size,/events/0/velocity_m_per_s,duration_s,peak,rms\n"
    ));
    assert_eq!(csv.lines().count(), 13);
}

#[test]
fn a_killed_batch_resumes_to_identical_files() {
    let d = tmp("kill");
    // 2 s items on one thread: long enough to be killed part-way.
    let spec = write_spec(&d, 25, 2.0);
    let clean = d.join("clean");
    batch(&["--threads", "2"], &spec, &clean);
    let total = wavs(&clean).len();
    assert_eq!(total, 100);

    let out = d.join("killed");
    let mut child = tactus()
        .arg("batch")
        .arg(&spec)
        .arg("-o")
        .arg(&out)
        .args(["--threads", "1"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    loop {
        let n = std::fs::read_dir(&out).map_or(0, |r| {
            r.filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .ends_with(".wav")
            })
            .count()
        });
        if n >= 5 || t0.elapsed() > Duration::from_secs(120) {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let partial = wavs(&out);
    assert!(
        partial.len() >= 5 && partial.len() < total,
        "kill landed outside the run: {} of {total} files",
        partial.len()
    );
    // Whatever was killed, every file under its final name is complete and correct.
    let clean_files: std::collections::BTreeMap<_, _> = wavs(&clean).into_iter().collect();
    for (n, bytes) in &partial {
        assert!(clean_files[n] == *bytes, "{n}: a partial file survived the kill");
    }
    assert!(
        !out.join("manifest.jsonl").exists(),
        "an unfinished run published its manifest"
    );

    let o = batch(&["--threads", "2"], &spec, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(&format!("{} already there", partial.len())), "{err}");
    assert_eq!(
        files(&out),
        files(&clean),
        "resumed batch differs from an uninterrupted one"
    );
    let hidden: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".partial"))
        .collect();
    assert!(hidden.is_empty(), "temporary files left: {hidden:?}");
}

#[test]
fn a_manifest_row_alone_re_renders_its_file() {
    let d = tmp("rerender");
    let spec = write_spec(&d, 2, 0.25);
    let out = d.join("out");
    batch(&[], &spec, &out);
    let jsonl = std::fs::read_to_string(out.join("manifest.jsonl")).unwrap();
    let row: serde_json::Value = serde_json::from_str(jsonl.lines().nth(5).unwrap()).unwrap();
    // The row's scene through `tactus render`, and the row itself as a one-line scenes file.
    let scene = d.join("row.json");
    std::fs::write(&scene, row["scene"].to_string()).unwrap();
    let again = d.join("again.wav");
    let o = tactus()
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&again)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let file = out.join(row["file"].as_str().unwrap());
    assert!(
        std::fs::read(&again).unwrap() == std::fs::read(&file).unwrap(),
        "re-render differs"
    );

    let lines = d.join("rows.jsonl");
    std::fs::write(&lines, format!("{row}\n")).unwrap();
    let o = tactus()
        .arg("batch")
        .arg("--scenes")
        .arg(&lines)
        .arg("-o")
        .arg(d.join("from_rows"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(d.join("from_rows/000000.wav")).unwrap() == std::fs::read(&file).unwrap());
}

#[test]
fn another_batch_in_the_same_folder_is_refused() {
    let d = tmp("refuse");
    let spec = write_spec(&d, 1, 0.1);
    let out = d.join("out");
    batch(&[], &spec, &out);
    let o = tactus()
        .arg("batch")
        .arg(&spec)
        .arg("-o")
        .arg(&out)
        .args(["--format", "pcm16"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("holds files of another batch") && err.lines().count() == 1,
        "{err}"
    );
}

#[test]
fn bad_specs_are_one_line_errors() {
    let d = tmp("badspec");
    std::fs::write(d.join("base.json"), r#"{"duration_s": 0.1, "material": "wood"}"#).unwrap();
    std::fs::write(
        d.join("base2.json"),
        r#"{"duration_s": 0.1, "material": "wood", "events": [{"type": "impact", "time_s": 0}]}"#,
    )
    .unwrap();
    let cases = [
        (
            r#"{"scene": "base.json", "params": [{"path": "/settings/damping", "log_uniform": [0.5, 200]}]}"#,
            "params[0] (/settings/damping) at 200",
        ),
        (
            r#"{"scene": "base.json", "params": [{"path": "/settings/damping", "log_uniform": [0, 2]}]}"#,
            "log_uniform needs 0 < lo <= hi",
        ),
        (
            r#"{"scene": "base.json", "params": [{"path": "/settings/damping", "uniform": [1, 2], "grid": [1]}]}"#,
            "exactly one of",
        ),
        (
            r#"{"scene": "base2.json", "params": [{"path": "/events/3/time_s", "uniform": [0, 0.05]}]}"#,
            "'3' is not an index of an array of 1",
        ),
        (
            r#"{"scene": "base.json", "params": [{"path": "settings", "uniform": [0, 1]}]}"#,
            "JSON pointer",
        ),
        (
            r#"{"scene": "base.json", "sampels": 3}"#,
            "unknown field `sampels`",
        ),
        (r#"{"scene": "missing.json"}"#, "cannot read scene"),
    ];
    for (k, (spec, needle)) in cases.iter().enumerate() {
        let p = d.join(format!("spec{k}.json"));
        std::fs::write(&p, spec).unwrap();
        let o = tactus()
            .arg("batch")
            .arg(&p)
            .arg("-o")
            .arg(d.join("out"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "spec {k} accepted");
        assert!(
            err.contains(needle) && err.trim_end().lines().count() == 1,
            "spec {k}: {err}"
        );
    }
    let o = tactus()
        .arg("batch")
        .arg(d.join("spec0.json"))
        .args(["-o", "x", "--shard", "2/2"])
        .output()
        .unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("0 <= I < N"));
}

/// `batch --limit` passes every render through the plugin's output limiter; without it the
/// float files keep their peaks above full scale. A folder rendered one way is not resumed the
/// other way (the option is part of the batch's fingerprint).
#[test]
fn limit_caps_every_file_and_is_part_of_the_fingerprint() {
    use tactus::engine::limiter::CEILING;
    let d = tmp("limit");
    std::fs::write(
        d.join("base.json"),
        r#"{"duration_s": 0.2, "material": "glass", "settings": {"gain_db": 24},
            "events": [{"type": "impact", "time_s": 0.01, "velocity_m_per_s": 10}]}"#,
    )
    .unwrap();
    let spec = d.join("spec.json");
    std::fs::write(
        &spec,
        r#"{"scene": "base.json", "samples": 1, "seed": 1, "params": [
            {"path": "/seed", "int_range": [1, 2]}]}"#,
    )
    .unwrap();
    let peak = |dir: &Path| {
        let w = wavs(dir);
        assert_eq!(w.len(), 2);
        w.iter()
            .flat_map(|(n, _)| {
                hound::WavReader::open(dir.join(n))
                    .unwrap()
                    .into_samples::<f32>()
                    .map(Result::unwrap)
                    .collect::<Vec<_>>()
            })
            .fold(0.0f32, |m, x| m.max(x.abs()))
    };
    let (free, limited) = (d.join("free"), d.join("limited"));
    batch(&["--format", "float32"], &spec, &free);
    batch(&["--format", "float32", "--limit"], &spec, &limited);
    assert!(
        peak(&free) > 2.0,
        "the test needs renders above full scale: {}",
        peak(&free)
    );
    assert!(peak(&limited) <= CEILING, "{}", peak(&limited));
    let o = tactus()
        .arg("batch")
        .arg(&spec)
        .arg("-o")
        .arg(&free)
        .args(["--format", "float32", "--limit"])
        .output()
        .unwrap();
    assert!(!o.status.success(), "an unlimited folder resumed with --limit");
}
