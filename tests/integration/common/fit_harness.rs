//! The plugin-fit tests' harness: a plugin activated on the stub host, parameters set as a host
//! sets them, blocks through `process` under an allocation guard, recordings (the shared ones or
//! synthesised), and the test that fits ten recordings through the editor's own fit path
//! ([`FitJob`]) while the audio thread processes. Used by `plugin_fit.rs`, `plugin_process.rs`
//! (a counting allocator) and `plugin_fit_rt.rs` (nice-plug's `assert_process_allocs`).
#![allow(dead_code)]

use nice_plug::midi::{Channel, Key, VoiceID};
use nice_plug::prelude::*;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tactus::plugin::fit_job::{FitJob, FitSettings};
use tactus::plugin::stub_host::StubHost;
use tactus::plugin::user_preset::USER_SLOT;
use tactus::plugin::Tactus;

/// Runs one `process` call and returns the allocations it made on this thread (a checker that
/// aborts on the first one returns 0).
pub type Guard<'a> = &'a dyn Fn(&mut dyn FnMut()) -> u64;

/// No check (renders whose allocations are not under test).
pub fn unguarded(f: &mut dyn FnMut()) -> u64 {
    f();
    0
}

pub const FS: f32 = 48_000.0;

pub fn plugin(mode: ProcessMode) -> Tactus {
    let mut p = Tactus::default();
    assert!(StubHost::new(FS).activate(&mut p, FS, 512, mode));
    p
}

/// Sets parameter `id` to the plain value `plain`, as a host would between blocks.
pub fn set(p: &Tactus, id: &str, plain: f32) {
    let params = p.params();
    let (_, ptr, _) = params
        .param_map()
        .into_iter()
        .find(|(i, _, _)| i == id)
        .unwrap_or_else(|| panic!("no parameter {id}"));
    unsafe {
        ptr._internal_set_normalized_value(ptr.preview_normalized(plain));
        ptr._internal_update_smoother(FS, false);
    }
}

pub fn note(timing: u32, key: u8) -> NoteEvent<()> {
    NoteEvent::NoteOn {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Number(key),
        velocity: 0.8,
    }
}

/// One block through the plugin's `process` under `guard`; returns the allocations it counted.
pub fn block(p: &mut Tactus, l: &mut [f32], r: &mut [f32], events: Vec<NoteEvent<()>>, guard: Guard) -> u64 {
    let n = l.len();
    let mut buffer = Buffer::default();
    unsafe {
        buffer.set_slices(n, |s| {
            s.clear();
            s.push(&mut *l);
            s.push(&mut *r);
        });
    }
    let mut ctx = StubHost::new(FS);
    ctx.set_events(events);
    let mut aux = AuxiliaryBuffers {
        inputs: &mut [],
        outputs: &mut [],
    };
    guard(&mut || {
        p.process(&mut buffer, &mut aux, &mut ctx);
    })
}

pub fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tactus_plugin_fit_{tag}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A 16-bit mono WAV of 0.5 s at 44.1 kHz with samples `f(i)`.
pub fn write_wav(path: &Path, f: impl Fn(usize) -> f64) {
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: 44_100,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut w = hound::WavWriter::create(path, spec).unwrap();
    for i in 0..22_050 {
        w.write_sample((f(i) * 32_767.0) as i16).unwrap();
    }
    w.finalize().unwrap();
}

/// A struck-object-like recording: five partials of `f0` with growing decay.
pub fn synthetic_object(path: &Path, f0: f64) {
    write_wav(path, |i| {
        let t = i as f64 / 44_100.0;
        (0..5)
            .map(|k| {
                let f = f0 * (1.0 + 1.9 * k as f64);
                0.15 * (-(8.0 + 6.0 * k as f64) * t).exp() * (std::f64::consts::TAU * f * t + k as f64).sin()
            })
            .sum()
    });
}

/// `n` synthesised object recordings in a fresh folder.
pub fn synthetic_set(tag: &str, n: usize) -> Vec<PathBuf> {
    let dir = temp_dir(tag);
    (0..n)
        .map(|k| {
            let p = dir.join(format!("object_{k:02}.wav"));
            synthetic_object(&p, 180.0 * 1.13f64.powi(k as i32));
            p
        })
        .collect()
}

/// Ten recordings: the first ten of the shared recordings, or ten synthesised ones (said so on
/// stderr) when the folder is absent.
pub fn ten_recordings() -> (Vec<PathBuf>, &'static str) {
    if let Some(dir) = crate::common::recordings() {
        let mut wavs: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "wav"))
            .collect();
        wavs.sort();
        // Wood recordings: the shared folder lists the metal ones first.
        wavs.retain(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("wood_"))
        });
        if wavs.len() >= 10 {
            wavs.truncate(10);
            return (wavs, "wood");
        }
    }
    eprintln!("note: fitting 10 synthesised recordings instead of the shared ones");
    (synthetic_set("ten", 10), "wood")
}

/// Fits ten recordings (and one that must be left out) through [`FitJob`] while the audio
/// thread processes blocks of 512, 64, 1 and 333 samples under `guard`, then selects the
/// fitted material and plays it: no block allocates, none waits for the fit, the fitted preset
/// is the user slot's and the project state's, and it reaches the engine.
pub fn fit_ten_while_processing(guard: Guard) {
    let mut p = plugin(ProcessMode::Realtime);
    set(&p, "material", 0.0);
    let (mut inputs, class) = ten_recordings();
    // One recording that cannot be fitted: it must be left out, with its reason.
    let silent = temp_dir("silent").join("silent.wav");
    write_wav(&silent, |_| 0.0);
    inputs.push(silent);
    let params = p.tactus_params();
    let generation = params.user_preset.generation();
    let settings = FitSettings {
        material_class: class.into(),
        ..FitSettings::default()
    };
    let job = FitJob::start(params.clone(), inputs, settings);

    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    let (mut blocks, mut slowest) = (0u32, Duration::ZERO);
    let mut seen_progress = Vec::new();
    let t0 = Instant::now();
    while !job.finished() {
        assert!(
            t0.elapsed() < Duration::from_secs(900),
            "fit still running after 15 min"
        );
        let len = [512, 64, 1, 333][blocks as usize % 4];
        let events = if blocks % 20 == 0 {
            vec![note(0, 60)]
        } else {
            vec![]
        };
        let start = Instant::now();
        let n = block(&mut p, &mut l[..len], &mut r[..len], events, guard);
        slowest = slowest.max(start.elapsed());
        assert_eq!(n, 0, "allocation in process while fitting, block {blocks}");
        assert!(l[..len].iter().chain(&r[..len]).all(|x| x.is_finite()));
        blocks += 1;
        let progress = job.progress();
        if seen_progress.last() != Some(&progress) {
            seen_progress.push(progress);
        }
        // A host calls process once per block period (512 samples ≈ 10.7 ms).
        std::thread::sleep(Duration::from_millis(5));
    }
    let fit_s = t0.elapsed().as_secs_f64();
    let report = job.wait().expect("the fit succeeds");
    eprintln!(
        "fitted {} recordings ({} left out) in {fit_s:.1} s while {blocks} blocks were processed; \
         slowest block {:.2} ms; progress seen {seen_progress:?}",
        report.fitted.len(),
        report.left_out.len(),
        slowest.as_secs_f64() * 1e3
    );
    assert_eq!(report.left_out.len(), 1, "{:?}", report.left_out);
    assert_eq!(report.left_out[0].name, "silent.wav");
    assert!(
        report.left_out[0].reason.contains("silent"),
        "{:?}",
        report.left_out
    );
    assert_eq!(report.fitted.len(), 10);
    assert!(
        seen_progress.iter().any(|&(d, t)| t == 11 && d < 11),
        "{seen_progress:?}"
    );
    // The audio thread ran all along: a block that waited for the fit would have waited for a
    // file's fit (seconds); 250 ms leaves room for a machine busy with other work.
    assert!(blocks > 10, "only {blocks} blocks processed during the fit");
    assert!(slowest < Duration::from_millis(250), "a block took {slowest:?}");
    // The fitted preset is the user slot's, and the project state holds it.
    assert_eq!(params.user_preset.json(), report.json);
    assert!(params.user_preset.generation() > generation);
    assert!(params.user_preset.status().is_empty());
    assert_eq!(
        params.serialize_fields()["user_preset"],
        serde_json::to_string(&report.json).unwrap()
    );

    // The editor then selects the user slot; the fitted material arrives without allocation.
    set(&p, "material", USER_SLOT as f32);
    let mut arrived = false;
    let mut peak = 0f32;
    for b in 0..400u32 {
        let events = if arrived && peak == 0.0 {
            vec![note(0, 60)]
        } else {
            vec![]
        };
        let n = block(&mut p, &mut l, &mut r, events, guard);
        assert_eq!(n, 0, "allocation in process after the fit, block {b}");
        if arrived {
            peak = l.iter().chain(&r).fold(peak, |m, x| m.max(x.abs()));
        }
        if p.object_key().material == USER_SLOT && p.object_key().library == params.user_preset.generation() {
            arrived = true;
        }
        if arrived && peak > 0.0 {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    assert!(arrived, "the fitted material never reached the engine");
    assert!(
        peak > 1e-4 && peak.is_finite(),
        "the fitted material is silent ({peak})"
    );
}

/// A note-on at full velocity.
pub fn full_note(timing: u32, key: u8) -> NoteEvent<()> {
    NoteEvent::NoteOn {
        timing,
        voice_id: VoiceID::Wildcard,
        channel: Channel::Wildcard,
        key: Key::Number(key),
        velocity: 1.0,
    }
}

/// The loudest plugin a user can set up: offline (every object and gesture body drawn in
/// `process`), the largest valid preset ([`tactus::preset::worst_case_preset`]) in the user
/// slot, every numeric control at its maximum (Gain, Velocity, Hardness, Mass, Height,
/// Restitution, Fragments, the scrape and roll speeds and pressures, Quality, …) and the
/// limiter as `limiter` says.
pub fn loudest_plugin(limiter: bool) -> Tactus {
    use std::collections::BTreeMap;
    let p = plugin(ProcessMode::Offline);
    let mut fields = BTreeMap::new();
    let json = tactus::preset::worst_case_preset().to_json();
    fields.insert("user_preset".to_string(), serde_json::to_string(&json).unwrap());
    p.params().deserialize_fields(&fields);
    set(&p, "material", USER_SLOT as f32);
    // Not numeric controls: which object (material, seed, its trigger), what keys and notes do
    // (set per phase by `loudest_render`), the limiter itself.
    let skip = [
        "material",
        "seed",
        "new_object",
        "note_mode",
        "gesture",
        "contact_model",
        "scrape_motion",
        "limiter",
    ];
    for (id, ptr, _) in p.params().param_map() {
        if !skip.contains(&id.as_str()) {
            unsafe {
                ptr._internal_set_normalized_value(1.0);
                ptr._internal_update_smoother(FS, false);
            }
        }
    }
    set(&p, "limiter", limiter as u8 as f32);
    p
}

/// Renders 0.5 s of [`loudest_plugin`] under `guard` in blocks of 512, 64, 1 and 333 samples:
/// 64 notes at full velocity at once on Strike, then 16 notes each of Break, Bounce and Rattle,
/// all while scraping and rolling. Returns both channels, one after the other.
pub fn loudest_render(p: &mut Tactus, guard: Guard) -> Vec<f32> {
    let total = (0.5 * FS) as usize;
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    let (mut out_l, mut out_r) = (Vec::with_capacity(total), Vec::with_capacity(total));
    let mut b = 0usize;
    // The gestures' phases start at these samples: Strike, Break, Bounce, Rattle.
    let phases = [0usize, 6_000, 12_000, 18_000];
    let mut phase = 0;
    while out_l.len() < total {
        let len = [512, 64, 1, 333][b % 4].min(total - out_l.len());
        let mut events = Vec::new();
        if phase < phases.len() && out_l.len() >= phases[phase] {
            set(p, "gesture", phase as f32);
            let notes = if phase == 0 { 64 } else { 16 };
            events = (0..notes)
                .map(|k| full_note((k as u32).min(len as u32 - 1), 30 + k as u8))
                .collect();
            phase += 1;
        }
        let n = block(p, &mut l[..len], &mut r[..len], events, guard);
        assert_eq!(n, 0, "allocation in process, block {b}");
        out_l.extend_from_slice(&l[..len]);
        out_r.extend_from_slice(&r[..len]);
        b += 1;
    }
    out_l.extend_from_slice(&out_r);
    out_l
}
