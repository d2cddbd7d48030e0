//! The engine scenes and their lever sweeps, the bank kernel rows and the scrape/roll rows.

use super::*;
use crate::engine::stereo::{pan_group, side_weight, DEFAULT_WIDTH};

/// An engine scene: events at absolute sample times.
#[derive(Clone)]
pub(super) struct EngineScene {
    pub(super) name: &'static str,
    pub(super) preset: Preset,
    pub(super) voices: usize,
    pub(super) len: usize,
    pub(super) settings: Settings,
    /// (sample time, velocity, pitch factor)
    pub(super) hits: Vec<(usize, f64, f64)>,
}

#[derive(Clone, Copy)]
pub(super) struct Lever {
    pub(super) quality_db: f64,
    pub(super) block: usize,
    pub(super) transient: bool,
    /// Mode culling on (static + dynamic); off (with `merging` off) is the unculled reference.
    pub(super) culling: bool,
    /// Re-strike merging on (`Engine::set_merging_enabled`).
    pub(super) merging: bool,
    /// Keep the output (for the error columns); off, the timed loop is the engine alone.
    pub(super) record: bool,
}

/// One render of an engine scene in progress: [`EngineRun::advance`] renders it block by block
/// up to a sample time, timing only the engine's work (the f32 copy of the output, when
/// recorded, is a memcpy inside the timed loop; the f64 conversion happens after it).
struct EngineRun<'a> {
    sc: &'a EngineScene,
    lv: Lever,
    e: Engine,
    s: Settings,
    l: Vec<f32>,
    r: Vec<f32>,
    out: Vec<f32>,
    events: Vec<Event>,
    hi: usize,
    pos: usize,
    /// CPU seconds spent in [`EngineRun::advance`] so far.
    secs: f64,
}

impl<'a> EngineRun<'a> {
    fn new(sc: &'a EngineScene, lv: Lever) -> Self {
        let mut e = Engine::new(&sc.preset, sc.voices, 7);
        e.prepare(FS, lv.block);
        e.set_transient_enabled(lv.transient);
        e.set_culling_enabled(lv.culling);
        e.set_merging_enabled(lv.merging);
        let mut s = sc.settings;
        s.output.quality_db = lv.quality_db;
        e.take_stats();
        Self {
            sc,
            lv,
            e,
            s,
            l: vec![0.0f32; lv.block],
            r: vec![0.0f32; lv.block],
            out: Vec::with_capacity(if lv.record { sc.len } else { 0 }),
            events: Vec::with_capacity(sc.hits.len()),
            hi: 0,
            pos: 0,
            secs: 0.0,
        }
    }

    /// Renders up to sample `end` (at most the scene's length) in whole blocks.
    fn advance(&mut self, end: usize) {
        let (sc, lv) = (self.sc, self.lv);
        let end = end.min(sc.len);
        let t0 = CpuClock::now();
        while self.pos < end {
            let pos = self.pos;
            let n = lv.block.min(sc.len - pos);
            self.events.clear();
            while self.hi < sc.hits.len() && sc.hits[self.hi].0 < pos + n {
                let (t, v, p) = sc.hits[self.hi];
                self.events.push(Event::Impact {
                    offset: (t - pos) as u32,
                    velocity_m_per_s: v,
                    pitch_factor: p,
                    key: -1,
                });
                self.hi += 1;
            }
            self.e
                .process(&self.s, &self.events, &mut self.l[..n], &mut self.r[..n]);
            if lv.record {
                // The fold-down (L + R)/2: the left channel itself at width 0 (x + x and the
                // halving are exact), the mono-compatible sum in stereo.
                self.out
                    .extend(self.l[..n].iter().zip(&self.r[..n]).map(|(a, b)| (a + b) * 0.5));
            }
            self.pos += n;
        }
        self.secs += t0.elapsed_secs();
    }

    fn finish(mut self) -> (Vec<f64>, Stats, f64) {
        let out = self.out.iter().map(|&x| x as f64).collect();
        (out, self.e.take_stats(), self.secs)
    }
}

/// Renders the scene with the levers; returns the output (the fold-down, when recorded), the
/// engine's stats and the CPU seconds of the render.
pub(super) fn run_engine(sc: &EngineScene, lv: Lever) -> (Vec<f64>, Stats, f64) {
    let mut run = EngineRun::new(sc, lv);
    run.advance(sc.len);
    run.finish()
}

/// Samples each scene of [`run_interleaved`] renders before the other takes its turn: 2 048
/// samples is 32 blocks of 64, about a millisecond of a 64-voice chord's work, so both scenes
/// see the same spells of a shared machine, while each still finds its own data in the caches
/// for most of its turn.
const INTERLEAVE_SAMPLES: usize = 2048;

/// Renders two scenes of the same length with the same levers in alternating turns of
/// [`INTERLEAVE_SAMPLES`] and returns each one's CPU seconds. Why: on a machine whose caches
/// and memory are shared with other work, run times of the same render vary by up to 2× from
/// one second to the next, so the ratio of two renders timed one after the other is that noise;
/// alternating every millisecond gives both the same machine.
pub(super) fn run_interleaved(a: &EngineScene, b: &EngineScene, lv: Lever) -> (f64, f64) {
    let (mut ra, mut rb) = (EngineRun::new(a, lv), EngineRun::new(b, lv));
    let len = a.len.max(b.len);
    let mut at = 0;
    while at < len {
        at += INTERLEAVE_SAMPLES;
        ra.advance(at);
        rb.advance(at);
    }
    (ra.secs, rb.secs)
}

pub(super) fn timed_engine(sc: &EngineScene, lv: Lever, reps: usize) -> (Vec<f64>, Stats, f64) {
    let (out, stats, mut best) = run_engine(sc, lv);
    for _ in 1..reps {
        best = best.min(run_engine(sc, lv).2);
    }
    (out, stats, best)
}

pub(super) fn preset(name: &str) -> Preset {
    builtin_presets()
        .into_iter()
        .find(|p| p.material_class == name || p.name.eq_ignore_ascii_case(name))
        .unwrap_or_else(|| builtin_presets().remove(0))
}

/// A derived 64-mode metal-like material (the shipped presets have 24 modes).
pub fn preset64() -> Preset {
    derived(&DerivedSpec {
        name: "Bench64",
        class: "metal",
        alpha1: 2.0,
        alpha2: 1e-8,
        freq_range_hz: (220.0, 12_000.0),
        count: 64,
        tilt_db_per_octave: -3.0,
        stiffness: 1e7,
        transient: (-20.0, 300.0),
    })
}

pub(super) struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

pub(super) fn scenes(quick: bool) -> Vec<EngineScene> {
    let secs = if quick { 1.0 } else { 3.0 };
    let len = (secs * FS) as usize;
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let dense: Vec<_> = (0..(secs * 100.0) as usize)
        .map(|i| {
            (
                (i as f64 * FS / 100.0 + rng.next() * 200.0) as usize,
                0.3 + 2.0 * rng.next(),
                0.8 + 0.4 * rng.next(),
            )
        })
        .collect();
    // A ball dropped on the object: restitution 0.75 from 2 m/s, flight 2·v/g between impacts
    // (18 impacts in 1.2 s, the last at 0.04 m/s).
    let mut bounces = Vec::new();
    let (mut t, mut v) = (0.0f64, 2.0f64);
    while v > 0.03 && t * FS < len as f64 {
        bounces.push(((t * FS) as usize, v, 1.0));
        v *= 0.75;
        t += 2.0 * v / 9.81;
    }
    // Repeated strikes on one object (a hammer, a MIDI pattern on one key): 4 per second,
    // velocity 0.5…1.5 m/s.
    let strikes: Vec<_> = (0..(secs * 4.0) as usize)
        .map(|i| ((i as f64 * FS / 4.0) as usize, 0.5 + rng.next(), 1.0))
        .collect();
    let chord_settings = settings_with(0.05, 300.0);
    vec![
        EngineScene {
            name: "single impact (wood)",
            preset: preset("wood"),
            voices: 64,
            len,
            settings: Settings::default(),
            hits: vec![(0, 1.0, 1.0)],
        },
        EngineScene {
            name: "single impact (metal)",
            preset: preset("metal"),
            voices: 64,
            len,
            settings: Settings::default(),
            hits: vec![(0, 1.0, 1.0)],
        },
        EngineScene {
            name: "bouncing ball (wood)",
            preset: preset("wood"),
            voices: 64,
            len,
            settings: Settings::default(),
            hits: bounces.clone(),
        },
        EngineScene {
            name: "bouncing ball (metal)",
            preset: preset("metal"),
            voices: 64,
            len,
            settings: Settings::default(),
            hits: bounces,
        },
        EngineScene {
            name: "repeated strikes (4/s, metal)",
            preset: preset("metal"),
            voices: 64,
            len,
            settings: Settings::default(),
            hits: strikes,
        },
        EngineScene {
            name: "dense impacts (100/s, glass)",
            preset: preset("glass"),
            voices: 64,
            len,
            settings: Settings::default(),
            hits: dense,
        },
        EngineScene {
            name: "64-voice chord (64 modes, damping 0.05)",
            preset: preset64(),
            voices: 64,
            len,
            settings: chord_settings,
            hits: (0..64)
                .map(|i| (0, 1.0, 2f64.powf((i as f64 - 32.0) / 48.0)))
                .collect(),
        },
    ]
}

pub(super) const QUALITIES: [f64; 9] = [20.0, 25.0, 30.0, 40.0, 60.0, 80.0, 120.0, 200.0, 300.0];

/// Runs every engine scene and lever; returns rows.
pub(super) fn engine_rows(
    quick: bool,
    reps: usize,
    keep: &dyn Fn(&str) -> bool,
    log: &mut dyn FnMut(&Row),
) -> Vec<Row> {
    let mut rows = Vec::new();
    for sc in scenes(quick).into_iter().filter(|s| keep(s.name)) {
        // The error reference: nothing skipped (no culling, every hit on a voice of its own),
        // 64-sample blocks, transient on.
        let base = Lever {
            quality_db: 300.0,
            block: 64,
            transient: true,
            culling: false,
            merging: false,
            record: true,
        };
        let (reference, _, _) = run_engine(&sc, base);
        let mut push = |lever: String, lv: Lever, rows: &mut Vec<Row>| {
            let (out, st, secs) = timed_engine(&sc, lv, reps);
            let mut r = row(
                sc.name,
                lever,
                sc.len,
                secs,
                st.mode_samples,
                snr_db(&reference, &out),
                erb_lsd_db(&reference, &out, FS),
            );
            r.frame_err_db = frame_erb_error_db(&reference, &out, FS);
            log(&r);
            rows.push(r);
        };
        let qualities: &[f64] = if sc.name.starts_with("64-voice") {
            &[60.0, 300.0]
        } else {
            &QUALITIES
        };
        push("culling=off".into(), base, &mut rows);
        for &q in qualities {
            push(
                format!("quality={q}"),
                Lever {
                    quality_db: q,
                    culling: true,
                    merging: true,
                    ..base
                },
                &mut rows,
            );
        }
        let default_q = Settings::default().output.quality_db;
        let q = if sc.name.starts_with("64-voice") {
            300.0
        } else {
            default_q
        };
        // Each lever alone: merging without culling, culling without merging.
        push(
            "merging only".into(),
            Lever {
                merging: true,
                ..base
            },
            &mut rows,
        );
        push(
            format!("no merging, quality={q}"),
            Lever {
                quality_db: q,
                culling: true,
                ..base
            },
            &mut rows,
        );
        for &b in &[1usize, 16, 256, 1024, 4096] {
            if quick && b == 1 {
                continue;
            }
            push(
                format!("q={q} block={b}"),
                Lever {
                    quality_db: q,
                    block: b,
                    transient: true,
                    culling: true,
                    merging: true,
                    record: true,
                },
                &mut rows,
            );
        }
        push(
            format!("q={q} transient=off"),
            Lever {
                quality_db: q,
                block: 64,
                transient: false,
                culling: true,
                merging: true,
                record: true,
            },
            &mut rows,
        );
    }
    rows
}

/// The scene of the stereo-cost rows: the 64-voice chord at width 0 and at the plugin's default.
pub const STEREO_CHORD: &str = "64-voice chord, stereo vs mono (64 modes, damping 0.05)";

/// The 64-voice chord (the polyphony scene) at width 0 (mono kernels) and at
/// [`DEFAULT_WIDTH`] (stereo kernels), at the default quality and the chord's 300, and the
/// stereo/mono ratio of their CPU times. Mono and stereo render in alternating turns of about
/// a millisecond ([`run_interleaved`]), so both see the same machine load; each row's time is
/// its fastest render, the ratio that of the summed times. The stereo row's error columns compare
/// its fold-down (L + R)/2 with the mono render (docs/model.md §10: equal but for f32
/// rounding). Returns the rows and the ratios `(quality, stereo / mono)`.
pub(super) fn stereo_rows(
    quick: bool,
    reps: usize,
    log: &mut dyn FnMut(&Row),
) -> (Vec<Row>, Vec<(f64, f64)>) {
    let Some(chord) = scenes(quick)
        .into_iter()
        .find(|s| s.name.starts_with("64-voice chord"))
    else {
        return (Vec::new(), Vec::new());
    };
    let with_width = |w: f64| {
        let mut sc = chord.clone();
        sc.name = STEREO_CHORD;
        sc.settings.output.width = w;
        sc
    };
    let (mono, stereo) = (with_width(0.0), with_width(DEFAULT_WIDTH));
    let (mut rows, mut ratios) = (Vec::new(), Vec::new());
    for q in [Settings::default().output.quality_db, 300.0] {
        let lv = Lever {
            quality_db: q,
            block: 64,
            transient: true,
            culling: true,
            merging: true,
            record: false,
        };
        // Each row's time is its fastest render; the ratio is of the summed times of renders
        // interleaved with each other ([`run_interleaved`]).
        let (mut tm, mut ts) = (f64::INFINITY, f64::INFINITY);
        let (mut sum_m, mut sum_s) = (0.0, 0.0);
        for _ in 0..reps.max(5) {
            let (m, s) = run_interleaved(&mono, &stereo, lv);
            tm = tm.min(m);
            ts = ts.min(s);
            sum_m += m;
            sum_s += s;
        }
        let ratio = sum_s / sum_m;
        let rec = Lever { record: true, ..lv };
        let (mono_out, mono_st, _) = run_engine(&mono, rec);
        let (st_out, st_st, _) = run_engine(&stereo, rec);
        let m = row(
            STEREO_CHORD,
            format!("width=0, quality={q}"),
            chord.len,
            tm,
            mono_st.mode_samples,
            f64::NAN,
            f64::NAN,
        );
        let mut s = row(
            STEREO_CHORD,
            format!("width={DEFAULT_WIDTH}, quality={q}"),
            chord.len,
            ts,
            st_st.mode_samples,
            snr_db(&mono_out, &st_out),
            erb_lsd_db(&mono_out, &st_out, FS),
        );
        s.frame_err_db = frame_erb_error_db(&mono_out, &st_out, FS);
        log(&m);
        log(&s);
        println!("stereo/mono chord CPU time at quality={q}: {ratio:.3}");
        ratios.push((q, ratio));
        rows.push(m);
        rows.push(s);
    }
    (rows, ratios)
}

/// Bank-level rows: f32 SIMD kernels vs the f64 recursion, one impulse into 64 modes.
pub(super) fn bank_rows(quick: bool, reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
    let len = if quick { 48_000 } else { 192_000 };
    let modes: Vec<ModeParams> = (0..64)
        .map(|i| ModeParams {
            freq_hz: 100.0 * 1.07f64.powi(i) + 3.0 * i as f64,
            decay_db_per_s: 1.0 + 0.2 * i as f64,
            gain: 0.02 / (1.0 + i as f64 * 0.05),
        })
        .collect();
    let mut input = vec![0.0f64; len];
    input[0] = 1.0;
    let t0 = CpuClock::now();
    let reference = render_modes_f64_recursive(&modes, FS, &input, len);
    let mut f64_secs = t0.elapsed_secs();
    for _ in 1..reps {
        let t0 = CpuClock::now();
        std::hint::black_box(render_modes_f64_recursive(&modes, FS, &input, len));
        f64_secs = f64_secs.min(t0.elapsed_secs());
    }
    let pans: Vec<u8> = (0..modes.len()).map(|i| pan_group(7, i)).collect();
    let side_modes: Vec<ModeParams> = modes
        .iter()
        .zip(&pans)
        .map(|(m, &p)| ModeParams {
            gain: m.gain * side_weight(p) as f32 as f64,
            ..*m
        })
        .collect();
    let side_reference = render_modes_f64_recursive(&side_modes, FS, &input, len);
    let mut rows = vec![row(
        "bank 64 modes, 1 impulse",
        "f64 recursion (reference)".into(),
        len,
        f64_secs,
        (64 * len) as u64,
        f64::INFINITY,
        0.0,
    )];
    log(&rows[0]);
    for k in [Kernel::Portable, Kernel::Avx2, Kernel::Avx512] {
        if !k.is_supported() {
            continue;
        }
        let block = 64;
        let run = || {
            let mut bank = ModalBank::with_capacity(64);
            bank.set_kernel(k);
            bank.set_sample_rate(FS);
            bank.set_modes(&modes);
            let mut out = vec![0.0f32; len];
            let mut inb = vec![0.0f32; block];
            let t0 = CpuClock::now();
            for (bi, chunk) in out.chunks_mut(block).enumerate() {
                if bi == 0 {
                    inb[0] = 1.0;
                    bank.process(Some(&inb[..chunk.len()]), chunk);
                } else {
                    bank.process(None, chunk);
                }
            }
            (out, t0.elapsed_secs())
        };
        let (out, mut secs) = run();
        for _ in 1..reps {
            secs = secs.min(run().1);
        }
        let out: Vec<f64> = out.iter().map(|&x| x as f64).collect();
        let r = row(
            "bank 64 modes, 1 impulse",
            format!("f32 kernel={k:?}"),
            len,
            secs,
            (64 * len) as u64,
            snr_db(&reference, &out),
            erb_lsd_db(&reference, &out, FS),
        );
        log(&r);
        rows.push(r);
        // The stereo bank on the same modes, each in its pan group (docs/model.md "Stereo
        // pickups"): mid and side per sample. Error: the worse of mid and side against their
        // f64 references (the side's has each gain times its side weight).
        let run_stereo = || {
            let mut bank = ModalBank::with_capacity(64);
            bank.set_kernel(k);
            bank.set_sample_rate(FS);
            bank.set_modes_panned(&modes, &pans);
            let mut mid = vec![0.0f32; len];
            let mut side = vec![0.0f32; len];
            let mut inb = vec![0.0f32; block];
            let t0 = CpuClock::now();
            for (bi, (m, s)) in mid.chunks_mut(block).zip(side.chunks_mut(block)).enumerate() {
                if bi == 0 {
                    inb[0] = 1.0;
                    bank.process_stereo(Some(&inb[..m.len()]), m, s);
                } else {
                    bank.process_stereo(None, m, s);
                }
            }
            (mid, side, t0.elapsed_secs())
        };
        let (mid, side, mut secs) = run_stereo();
        for _ in 1..reps {
            secs = secs.min(run_stereo().2);
        }
        let mid: Vec<f64> = mid.iter().map(|&x| x as f64).collect();
        let side: Vec<f64> = side.iter().map(|&x| x as f64).collect();
        let r = row(
            "bank 64 modes, 1 impulse",
            format!("f32 stereo kernel={k:?}"),
            len,
            secs,
            (64 * len) as u64,
            snr_db(&reference, &mid).min(snr_db(&side_reference, &side)),
            erb_lsd_db(&reference, &mid, FS).max(erb_lsd_db(&side_reference, &side, FS)),
        );
        log(&r);
        rows.push(r);
    }
    rows
}

/// The measured surface of the bench's measured scrape and roll rows: the roughest scan (its
/// RMS height 14 µm), a long file's statistics; every measured surface runs the same synthesis,
/// so its cost stands for theirs.
pub(super) const MEASURED_SURFACE: SurfaceKind = SurfaceKind::Pvc;

/// Name of the row of `kind` on the measured surface with `n_modes` modes.
pub(super) fn measured_row_name(kind: ContactKind, n_modes: usize) -> String {
    format!(
        "{kind:?} on {} (measured), {n_modes}-mode object",
        MEASURED_SURFACE.name()
    )
}

/// Scrape and roll through `SustainedVoice` + `ModalBank`: the synthetic surface on the
/// force generator alone, 24 and 64 modes, and the 64-mode object on a measured surface
/// ([`MEASURED_SURFACE`]) with its CPU time's ratio to the synthetic row's in the lever column.
/// Rows whose name `keep` refuses are not run (a measured row still times its synthetic
/// counterpart, for the ratio).
pub(super) fn sustained_rows(
    quick: bool,
    reps: usize,
    keep: &dyn Fn(&str) -> bool,
    log: &mut dyn FnMut(&Row),
) -> Vec<Row> {
    let len = if quick { 48_000 } else { 144_000 };
    // The target's object: 64 modes (the bench's derived metal-like material).
    let mut e = Engine::new(&preset64(), 1, 3);
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
    let full = modes.len();
    let mut rows = Vec::new();
    for kind in [ContactKind::Scrape, ContactKind::Roll] {
        // `n_modes` = 0: the force generator alone (its cost does not depend on the object).
        let run = |n_modes: usize, surface: SurfaceKind| {
            let p = SustainedParams {
                kind,
                surface,
                ..SustainedParams::default()
            };
            let mut sv = SustainedVoice::new(FS, 11);
            let mut bank = ModalBank::with_capacity(modes.len());
            bank.set_sample_rate(FS);
            bank.set_modes(&modes[..n_modes]);
            let mut imp = vec![0.0f32; 64];
            let mut out = vec![0.0f32; len];
            let t0 = CpuClock::now();
            for chunk in out.chunks_mut(64) {
                let n = chunk.len();
                let live = sv.process(&p, None, &mut imp[..n]);
                if n_modes > 0 {
                    bank.process(if live { Some(&imp[..n]) } else { None }, chunk);
                } else {
                    chunk.copy_from_slice(&imp[..n]);
                }
            }
            t0.elapsed_secs()
        };
        let timed = |n_modes: usize, surface: SurfaceKind| {
            (0..reps.max(1))
                .map(|_| run(n_modes, surface))
                .fold(f64::INFINITY, f64::min)
        };
        let measured = measured_row_name(kind, full);
        let mut synthetic_full = f64::NAN;
        for n_modes in [0, 24.min(full), full] {
            let name = format!("{kind:?}, {n_modes}-mode object");
            let for_ratio = n_modes == full && keep(&measured);
            if !keep(&name) && !for_ratio {
                continue;
            }
            let secs = timed(n_modes, SurfaceKind::Synthetic);
            if n_modes == full {
                synthetic_full = secs;
            }
            if !keep(&name) {
                continue;
            }
            let lever = if n_modes == 0 {
                "force generator only".to_string()
            } else {
                "default speed".to_string()
            };
            let r = row(
                &name,
                lever,
                len,
                secs,
                (n_modes * len) as u64,
                f64::NAN,
                f64::NAN,
            );
            log(&r);
            rows.push(r);
        }
        if keep(&measured) {
            let secs = timed(full, MEASURED_SURFACE);
            let lever = format!("measured/synthetic {:.3}", secs / synthetic_full);
            let r = row(
                &measured,
                lever,
                len,
                secs,
                (full * len) as u64,
                f64::NAN,
                f64::NAN,
            );
            log(&r);
            rows.push(r);
        }
    }
    rows
}
