//! Dense objects: a cymbal-like object of [`MAX_MODES`] modes (a 64-mode distribution and a
//! dense mode field filling the rest), struck once and as a 64-voice chord, its bank alone, and
//! the worst-case draw of such an object. Compare with the 64-mode rows of the same run
//! ("bank 64 modes", "64-voice chord (64 modes, …)").

use super::*;
use crate::engine::limits::MAX_MODES;
use crate::engine::object::{EngineRng, ObjectSampler, SampledObject};
use crate::preset::{worst_case_preset, DenseBand, DenseField};
use rand::SeedableRng;

/// The bench's 64-mode metal ([`preset64`]) with a dense field over 200 Hz–16 kHz asking for
/// [`MAX_MODES`] modes (so every object fills the limit): levels 20 ± 6 dB under the
/// strongest mode, decays around 20 dB/s (a 3 s ring, as a ride cymbal's partials).
pub fn dense_preset() -> Preset {
    let mut p = preset64();
    p.name = "BenchDense".into();
    let edges: Vec<f64> = (0..=19).map(|k| 200.0 * 2f64.powf(k as f64 / 3.0)).collect();
    let n = (edges.len() - 1) as f64;
    p.dense = Some(DenseField {
        bands: edges
            .windows(2)
            .map(|e| DenseBand {
                low_hz: e[0],
                high_hz: e[1],
                modes: MAX_MODES as f64 / n,
                level_db: -20.0,
                level_sd_db: 6.0,
                ln_decay: 20f64.ln(),
                ln_decay_sd: 0.3,
                rise_s: 0.0,
            })
            .collect(),
    });
    p
}

/// The dense rows: engine scenes (one hit; a 64-voice chord), the bank alone, the draw.
pub(super) fn dense_rows(quick: bool, reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    let len = if quick { 48_000 } else { 144_000 };
    let preset = dense_preset();
    let mut rows = Vec::new();
    let mut push = |r: Row, rows: &mut Vec<Row>| {
        log(&r);
        rows.push(r);
    };
    let name_one = format!("dense object ({MAX_MODES} modes), one hit");
    let name_chord = format!("64-voice chord ({MAX_MODES} modes, damping 0.05)");
    let scenes = [
        (name_one.as_str(), Settings::default(), vec![(0, 1.0, 1.0)]),
        (
            name_chord.as_str(),
            settings_with(0.05, 300.0),
            (0..64)
                .map(|i| (0, 1.0, 2f64.powf((i as f64 - 32.0) / 48.0)))
                .collect(),
        ),
    ];
    for (name, settings, hits) in scenes {
        let sc = EngineScene {
            name: "dense",
            preset: preset.clone(),
            voices: 64,
            len,
            settings,
            hits,
        };
        for (lever, culling) in [("culling=off", false), ("culling on", true)] {
            let lv = Lever {
                quality_db: settings.output.quality_db,
                block: 64,
                transient: true,
                culling,
                merging: culling,
                record: false,
            };
            let (_, st, secs) = timed_engine(&sc, lv, reps);
            let lever = if culling {
                format!("quality={}", settings.output.quality_db)
            } else {
                lever.to_string()
            };
            push(
                row(name, lever, len, secs, st.mode_samples, f64::NAN, f64::NAN),
                &mut rows,
            );
        }
    }
    for r in sixteen_voice_rows(&preset, len, reps) {
        push(r, &mut rows);
    }
    // The bank alone, as the "bank 64 modes" rows: one impulse, 64-sample blocks.
    let mut e = Engine::new(&preset, 1, 7);
    e.prepare(FS, 64);
    let modes: Vec<ModeParams> = e
        .object()
        .modes
        .iter()
        .map(|m| ModeParams {
            freq_hz: m.freq_hz,
            decay_db_per_s: m.decay_db_per_s,
            gain: 10f64.powf(m.level_db / 20.0),
        })
        .collect();
    let run = || {
        let mut bank = ModalBank::with_capacity(MAX_MODES);
        bank.set_sample_rate(FS);
        bank.set_modes(&modes);
        let mut out = vec![0.0f32; len];
        let mut inb = vec![0.0f32; 64];
        inb[0] = 1.0;
        let t0 = CpuClock::now();
        for (bi, chunk) in out.chunks_mut(64).enumerate() {
            let n = chunk.len();
            bank.process((bi == 0).then_some(&inb[..n]), chunk);
        }
        std::hint::black_box(&out);
        t0.elapsed_secs()
    };
    let mut secs = run();
    for _ in 1..reps {
        secs = secs.min(run());
    }
    push(
        row(
            &format!("bank {} modes, 1 impulse", modes.len()),
            format!("f32 kernel={:?}", Kernel::detect()),
            len,
            secs,
            (modes.len() * len) as u64,
            f64::NAN,
            f64::NAN,
        ),
        &mut rows,
    );
    // The worst-case draw: the largest Gaussian and a dense field to the limit.
    let worst = worst_case_preset();
    let mut sampler = ObjectSampler::new(&worst);
    let mut out = SampledObject::with_capacity();
    let mut slowest = 0.0f64;
    for seed in 0..16u64 {
        let mut best = f64::INFINITY;
        for _ in 0..reps.max(5) {
            let mut rng = EngineRng::seed_from_u64(seed);
            let t0 = CpuClock::now();
            sampler.sample(&mut rng, &mut out);
            best = best.min(t0.elapsed_secs());
            std::hint::black_box(&out);
        }
        slowest = slowest.max(best);
    }
    push(
        row(
            "new object drawn (ObjectSampler::sample, worst seed)",
            format!(
                "worst_case_preset: Gaussian + dense field, {} modes",
                out.modes.len()
            ),
            64,
            slowest,
            0,
            f64::NAN,
            f64::NAN,
        ),
        &mut rows,
    );
    rows
}

/// The scene of the dense-polyphony target: 16 dense objects ringing at once (16 hits at t = 0,
/// pitch factors spread over ±8 semitones so no two merge), default settings.
pub const SIXTEEN_DENSE: &str = "16 dense voices (1024 modes, default settings)";

/// [`SIXTEEN_DENSE`] with nothing skipped (the full bank, the error reference) and at the
/// default quality, with the error columns against the full bank.
fn sixteen_voice_rows(preset: &Preset, len: usize, reps: usize) -> Vec<Row> {
    let sc = EngineScene {
        name: SIXTEEN_DENSE,
        preset: preset.clone(),
        voices: 64,
        len,
        settings: Settings::default(),
        hits: (0..16)
            .map(|i| (0, 1.0, 2f64.powf((i as f64 - 7.5) / 7.5 * 8.0 / 12.0)))
            .collect(),
    };
    let full = Lever {
        quality_db: Settings::default().output.quality_db,
        block: 64,
        transient: true,
        culling: false,
        merging: false,
        record: true,
    };
    let (reference, _, _) = run_engine(&sc, full);
    let mut rows = Vec::new();
    for (lever, lv) in [
        ("culling=off (full bank)".to_string(), full),
        (
            format!("quality={} (default)", full.quality_db),
            Lever {
                culling: true,
                merging: true,
                ..full
            },
        ),
    ] {
        let (out, st, secs) = timed_engine(&sc, lv, reps);
        let mut r = row(
            sc.name,
            lever,
            len,
            secs,
            st.mode_samples,
            snr_db(&reference, &out),
            erb_lsd_db(&reference, &out, FS),
        );
        r.frame_err_db = frame_erb_error_db(&reference, &out, FS);
        rows.push(r);
    }
    rows
}
