//! "Skip what isn't needed": what idle, sleeping or culled work costs against its active
//! counterpart.

use super::*;

/// Measures the cost of what should be (almost) free against its active counterpart.
pub(super) fn skip_rows(reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    // These rows are short (an idle 2 s costs ~15 µs), so one preemption or clock read moves
    // them by percent: every row here, active and idle alike, takes the best of ≥ 25 repeats.
    let reps = reps.max(25);
    let len = 96_000;
    let p64 = preset64();
    let ringing = Settings {
        damping: 0.0,
        quality_db: 300.0,
        ..Settings::default()
    };
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
            quality_db: s.quality_db,
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
        Settings {
            damping: 20.0,
            ..Settings::default()
        },
    );
    time(
        "one ringing voice, quality 20 dB (most modes culled)",
        "-",
        vec![(0, 1.0, 1.0)],
        Settings {
            damping: 0.0,
            quality_db: 20.0,
            ..Settings::default()
        },
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
    // The floor under the idle engine: making the two output buffers zero, which every block
    // must do (a host may hand over dirty buffers), with the same kernel and block loop: storing
    // zeros (`zero_pair`) and the idle path's check of buffers that are already clean
    // (`clear_pair`, which then stores nothing).
    let kernel = Kernel::detect();
    for (name, store) in [
        ("storing zeros to both outputs (zero_pair)", true),
        ("checking clean outputs (clear_pair, no store)", false),
    ] {
        for block in [64, 512] {
            let (mut l, mut r) = (vec![0.0f32; block], vec![0.0f32; block]);
            let run = |l: &mut [f32], r: &mut [f32]| {
                let t0 = CpuClock::now();
                let mut pos = 0;
                while pos < long {
                    let n = block.min(long - pos);
                    let k = std::hint::black_box(kernel);
                    if store {
                        crate::engine::modal::zero_pair(k, &mut l[..n], &mut r[..n]);
                    } else {
                        crate::engine::modal::clear_pair(k, &mut l[..n], &mut r[..n]);
                    }
                    std::hint::black_box(&mut *l);
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
