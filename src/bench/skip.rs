//! "Skip what isn't needed": what idle, sleeping or culled work costs against its active
//! counterpart.

use super::*;
use crate::engine::dsp::linalg::cholesky;
use crate::engine::limits::MAX_DISTRIBUTION_MODES;
use crate::engine::modal::{clear_pair, zero_pair};
use crate::engine::object::{EngineRng, ObjectSampler, SampledObject, MAX_REJECTION_TRIES};
use crate::plugin::stub_host::StubHost;
use crate::plugin::Tactus;
use crate::preset::ModeModel;
use nice_plug::prelude::*;
use rand::SeedableRng;

/// Measures the cost of what should be (almost) free against its active counterpart.
pub(super) fn skip_rows(reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    // These rows are short (an idle 2 s costs ~15 µs), so one preemption or clock read moves
    // them by percent: every row here, active and idle alike, takes the best of ≥ 25 repeats.
    let reps = reps.max(25);
    let len = 96_000;
    let p64 = preset64();
    let ringing = settings_with(0.0, 300.0);
    let mut rows = Vec::new();
    let mut time_block = |name: &str,
                          lever: &str,
                          hits: Vec<(usize, f64, f64)>,
                          s: Settings,
                          block: usize,
                          len: usize,
                          reps: usize| {
        let sc = EngineScene {
            name: "skip",
            preset: p64.clone(),
            voices: 64,
            len,
            settings: s,
            hits,
        };
        let lv = Lever {
            quality_db: s.output.quality_db,
            block,
            transient: false,
            culling: true,
            merging: true,
            record: false,
        };
        let (_, st, secs) = timed_engine(&sc, lv, reps);
        let r = row(name, lever.into(), len, secs, st.mode_samples, f64::NAN, f64::NAN);
        log(&r);
        rows.push(r);
    };
    // The idle ratio rows run 20 s of audio: an idle 2 s is ~10 µs, where the two clock reads
    // alone would add a few percent. They are cheap per repeat (an idle 20 s is ~100 µs), so
    // they take 4× the repeats: a slow spell of the VM must last through all of them.
    let (long, long_reps) = (10 * len, 4 * reps);
    for block in [64, 512] {
        time_block(
            "idle engine (64 voice slots, none active)",
            &format!("block {block}"),
            vec![],
            ringing,
            block,
            long,
            long_reps,
        );
        time_block(
            "one ringing 64-mode voice (damping 0)",
            &format!("block {block}"),
            vec![(0, 1.0, 1.0)],
            ringing,
            block,
            long,
            long_reps,
        );
    }
    let mut time = |name: &str, lever: &str, hits: Vec<(usize, f64, f64)>, s: Settings| {
        time_block(name, lever, hits, s, 64, len, reps)
    };
    // A soft hit with fast decay (damping 20): the voice rings for a small part of the 2 s
    // window and sleeps (below −110 dBFS) for the rest, so the row is dominated by the sleeping
    // cost; its mode-samples show how little ringing is included.
    time(
        "voice asleep after decay (hit once, default damping, 2 s)",
        "-",
        vec![(0, 0.05, 1.0)],
        settings_with(20.0, Settings::default().output.quality_db),
    );
    time(
        "one ringing voice, quality 20 dB (most modes culled)",
        "-",
        vec![(0, 1.0, 1.0)],
        settings_with(0.0, 20.0),
    );
    // Scrape at zero speed vs default speed (SustainedVoice + bank; the bank free-rings).
    for (label, speed) in [
        ("scrape at zero speed (bank idle, 0 modes)", 0.0),
        ("scrape at default speed", 1.0),
    ] {
        let p = SustainedParams {
            scrape_speed_m_per_s: 0.3 * speed,
            ..SustainedParams::default()
        };
        let modes: Vec<ModeParams> = (0..64)
            .map(|i| ModeParams {
                freq_hz: 200.0 + 150.0 * i as f64,
                decay_db_per_s: 20.0,
                gain: 0.01,
            })
            .collect();
        let run = || {
            let mut sv = SustainedVoice::new(FS, 5);
            let mut bank = ModalBank::with_capacity(64);
            bank.set_sample_rate(FS);
            let mut imp = vec![0.0f32; 64];
            let mut out = vec![0.0f32; len];
            let mut computed = 0u64;
            let t0 = CpuClock::now();
            for chunk in out.chunks_mut(64) {
                let n = chunk.len();
                let live = sv.process(&p, None, &mut imp[..n]);
                if live && bank.active() == 0 {
                    bank.set_modes(&modes);
                }
                if bank.active() > 0 {
                    bank.process(if live { Some(&imp[..n]) } else { None }, chunk);
                    computed += (bank.active() * n) as u64;
                }
            }
            (computed, t0.elapsed_secs())
        };
        let (computed, mut secs) = run();
        for _ in 1..reps {
            secs = secs.min(run().1);
        }
        let r = row(label, "-".into(), len, secs, computed, f64::NAN, f64::NAN);
        log(&r);
        rows.push(r);
    }
    rows.extend(zeroing_rows(long, long_reps, log));
    rows.extend(plugin_idle_rows(long, long_reps, log));
    rows
}

/// One way of making an idle block's two outputs zero.
#[derive(Clone, Copy)]
enum Zeroing {
    /// [`zero_pair`]: `slice::fill(0.0)` on both outputs (LLVM lowers it to `memset`).
    Fill,
    /// `ptr::write_bytes` on both outputs.
    WriteBytes,
    /// [`clear_pair`] on outputs that are already zero (the AVX-512 check, no store).
    CheckClean,
}

/// The floor under the idle engine: making the two output buffers zero, which every block must
/// do (a host may hand over dirty buffers), in the same block loop, by each [`Zeroing`]. The
/// buffers are `Vec`s (16-byte aligned at least, as host buffers often are).
pub(super) fn zeroing_rows(long: usize, long_reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    let mut rows = Vec::new();
    let ways = [
        ("storing zeros to both outputs (zero_pair: fill)", Zeroing::Fill),
        (
            "storing zeros to both outputs (ptr::write_bytes)",
            Zeroing::WriteBytes,
        ),
        (
            "checking clean outputs (clear_pair, no store)",
            Zeroing::CheckClean,
        ),
    ];
    let kernel = Kernel::detect();
    for (name, way) in ways {
        for block in [64, 512] {
            let (mut l, mut r) = (vec![0.0f32; block], vec![0.0f32; block]);
            let run = |l: &mut [f32], r: &mut [f32]| {
                let t0 = CpuClock::now();
                let mut pos = 0;
                while pos < long {
                    let n = block.min(long - pos);
                    let (l, r) = (
                        std::hint::black_box(&mut l[..n]),
                        std::hint::black_box(&mut r[..n]),
                    );
                    match std::hint::black_box(way) {
                        Zeroing::Fill => zero_pair(l, r),
                        Zeroing::WriteBytes => {
                            // SAFETY: each pointer starts a live, exclusively borrowed slice of
                            // `n` f32s, and all-zero bytes are a valid f32 (+0.0).
                            unsafe {
                                std::ptr::write_bytes(l.as_mut_ptr(), 0, n);
                                std::ptr::write_bytes(r.as_mut_ptr(), 0, n);
                            }
                        }
                        Zeroing::CheckClean => clear_pair(kernel, l, r),
                    }
                    std::hint::black_box(&mut *l);
                    std::hint::black_box(&mut *r);
                    pos += n;
                }
                t0.elapsed_secs()
            };
            // The idle rows' repeat count: the floors are compared with them.
            let mut secs = run(&mut l, &mut r);
            for _ in 1..long_reps {
                secs = secs.min(run(&mut l, &mut r));
            }
            let row = row(name, format!("block {block}"), long, secs, 0, f64::NAN, f64::NAN);
            log(&row);
            rows.push(row);
        }
    }
    rows
}

/// The idle plugin: blocks of 64 samples through the plugin's own `process` (default
/// parameters, nothing sounding, no events), as a host calls it between notes: a real-time
/// activation at 48 kHz with blocks of up to 512, a stopped transport, output buffers that hold
/// the previous block's zeros (the common case: a host hands the same buffers back). The
/// wrapper's own per-block work (event queues, parameter flushes) is not included. Compared in
/// `results.md` with the engine's "one ringing 64-mode voice" row at the same block size.
pub(super) fn plugin_idle_rows(long: usize, long_reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    let block = 64;
    let mut plugin = Tactus::default();
    let mut host = StubHost::new(FS as f32);
    assert!(host.activate(&mut plugin, FS as f32, 512, ProcessMode::Realtime));
    let (mut l, mut r) = (vec![0.0f32; block], vec![0.0f32; block]);
    let mut buffer = Buffer::default();
    // SAFETY: both slices are live for as long as `buffer` is used (to the end of this function)
    // and have `block` samples each.
    unsafe {
        buffer.set_slices(block, |s| {
            s.clear();
            s.push(&mut l);
            s.push(&mut r);
        });
    }
    let process = |plugin: &mut Tactus, buffer: &mut Buffer, host: &mut StubHost| {
        let mut aux = AuxiliaryBuffers {
            inputs: &mut [],
            outputs: &mut [],
        };
        plugin.process(buffer, &mut aux, host);
    };
    // The first block draws the object; the timed ones find it in place.
    process(&mut plugin, &mut buffer, &mut host);
    let mut best = f64::INFINITY;
    for _ in 0..long_reps {
        let t0 = CpuClock::now();
        let mut pos = 0;
        while pos < long {
            process(&mut plugin, &mut buffer, &mut host);
            pos += block;
        }
        best = best.min(t0.elapsed_secs());
    }
    let silent = buffer.as_slice().iter().all(|ch| ch.iter().all(|v| *v == 0.0));
    assert!(silent, "the idle plugin must output silence");
    let row = row(
        "idle plugin (Tactus::process, default parameters, nothing sounding)",
        format!("block {block}"),
        long,
        best,
        0,
        f64::NAN,
        f64::NAN,
    );
    log(&row);
    vec![row]
}

/// Worst case of drawing a new object: a [`MAX_DISTRIBUTION_MODES`]-mode distribution with a full
/// covariance (every mode's level, decay and frequency correlated with every other's: a dense
/// 384-dimensional Cholesky product per try) and a spacing tolerance of 0, so every draw makes
/// all [`MAX_REJECTION_TRIES`] tries. Time per draw, max over seeds (each seed's draw the best
/// of `reps`); the "% core" column is relative to one 64-sample block at 48 kHz (1.33 ms), the
/// budget it takes when drawn on the audio thread. A second row draws the same preset at its
/// own tolerance (10 %): what a draw typically costs.
pub(super) fn draw_rows(reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    let seeds = 16u64;
    let reps = reps.max(5);
    let mut preset = derived(&DerivedSpec {
        name: "BenchMaxModes",
        class: "metal",
        alpha1: 2.0,
        alpha2: 1e-8,
        freq_range_hz: (110.0, 16_000.0),
        count: MAX_DISTRIBUTION_MODES,
        tilt_db_per_octave: -3.0,
        stiffness: 1e7,
        transient: (-20.0, 300.0),
    });
    let ModeModel::Distribution(d) = &mut preset.modes else {
        unreachable!("derived presets are distributions")
    };
    // Couple every pair of coordinates: ρ = 0.002 keeps the matrix diagonally dominant
    // (383·0.002 < 1), so it stays positive definite.
    let cov = &mut d.gaussian.covariance;
    let dim = cov.len();
    let sd: Vec<f64> = (0..dim).map(|i| cov[i][i].sqrt()).collect();
    for i in 0..dim {
        for j in 0..dim {
            if i != j {
                cov[i][j] = 0.002 * sd[i] * sd[j];
            }
        }
    }
    assert!(
        cholesky(cov).is_some(),
        "the coupled covariance must stay positive definite"
    );
    let tolerance = d.spacing_tolerance;
    let mut rows = Vec::new();
    for (lever, tol) in [
        (
            format!("{MAX_DISTRIBUTION_MODES} modes, full covariance, {MAX_REJECTION_TRIES} tries"),
            0.0,
        ),
        (
            format!("{MAX_DISTRIBUTION_MODES} modes, full covariance, tolerance {tolerance}"),
            tolerance,
        ),
    ] {
        if let ModeModel::Distribution(d) = &mut preset.modes {
            d.spacing_tolerance = tol;
        }
        let mut sampler = ObjectSampler::new(&preset);
        let mut out = SampledObject::with_capacity();
        let mut worst = 0.0f64;
        for seed in 0..seeds {
            let mut best = f64::INFINITY;
            for _ in 0..reps {
                let mut rng = EngineRng::seed_from_u64(seed);
                let t0 = CpuClock::now();
                sampler.sample(&mut rng, &mut out);
                best = best.min(t0.elapsed_secs());
                std::hint::black_box(&out);
            }
            worst = worst.max(best);
        }
        let row = row(
            "new object drawn (ObjectSampler::sample, worst seed)",
            lever,
            64,
            worst,
            0,
            f64::NAN,
            f64::NAN,
        );
        log(&row);
        rows.push(row);
    }
    rows
}
