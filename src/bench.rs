//! `tactus bench`: run time against error for fixed scenes and levers (quality, re-strike
//! merging, block size, transient, f32 bank vs f64 reference, kernel variant), and the "skip
//! what isn't needed" table.
//!
//! Timing is the thread's CPU time, min over repetitions (the machine is shared; see
//! `docs/bench/README.md`). Errors are measured against a reference render of the same scene:
//! - engine scenes: the same scene with nothing skipped (culling and merging off), same seed,
//!   transient on, block 64. The f32 bank itself is ≥ 130 dB SNR from the f64 recursion (rows
//!   `bank 64 modes`), so this reference stands for the unculled f64 render.
//! - bank rows: the f64 recursion [`render_modes_f64_recursive`] on the same modes and input.
//!
//! Error measures: SNR (`snr_db`) and the ERB-band log-spectral distance [`erb_lsd_db`].

use crate::engine::materials::{builtin_presets, derived, DerivedSpec};
use crate::engine::modal::{Kernel, ModalBank, ModeParams};
use crate::engine::object::{erb_bandwidth_hz, erb_centres};
use crate::engine::reference::{render_modes_f64_recursive, snr_db};
use crate::engine::sustained::{ContactKind, SustainedParams, SustainedVoice};
use crate::engine::{Engine, Event, Settings, Stats};
use crate::preset::Preset;
use realfft::RealFftPlanner;
use std::fmt::Write as _;
use std::path::Path;

/// Sample rate of all scenes.
pub const FS: f64 = 48_000.0;
/// Number of ERB bands of [`erb_lsd_db`].
pub const LSD_BANDS: usize = 36;
/// Floor of [`erb_lsd_db`], dB below the loudest reference band.
pub const LSD_FLOOR_DB: f64 = 80.0;

/// Timer for the benchmark: this thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`) on Unix, so other
/// processes competing for the two cores do not inflate the figures (they still share caches);
/// wall clock elsewhere.
struct CpuClock(f64);

impl CpuClock {
    fn now() -> Self {
        Self(Self::seconds())
    }

    fn elapsed_secs(&self) -> f64 {
        Self::seconds() - self.0
    }

    #[cfg(unix)]
    fn seconds() -> f64 {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; the clock id is a constant libc knows.
        let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
        if rc == 0 {
            ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
        } else {
            Self::wall()
        }
    }

    #[cfg(not(unix))]
    fn seconds() -> f64 {
        Self::wall()
    }

    fn wall() -> f64 {
        use std::sync::OnceLock;
        static START: OnceLock<std::time::Instant> = OnceLock::new();
        START.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
    }
}

/// ERB-band log-spectral distance in dB: the power spectrum of each whole signal is summed into
/// [`LSD_BANDS`] ERB-spaced bands (one ERB wide, 50 Hz … min(16 kHz, 0.45·fs)); band energies in
/// dB are floored at [`LSD_FLOOR_DB`] below the loudest reference band; the result is the RMS
/// over bands of the dB difference. 0 = identical band energies.
pub fn erb_lsd_db(reference: &[f64], test: &[f64], fs: f64) -> f64 {
    let n = reference.len().min(test.len());
    if n < 2 {
        return 0.0;
    }
    let nfft = n.next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let power = |x: &[f64]| -> Vec<f64> {
        let mut buf = vec![0.0; nfft];
        buf[..n].copy_from_slice(&x[..n]);
        let mut s = fft.make_output_vec();
        fft.process(&mut buf, &mut s).expect("fft sizes");
        s.iter().map(|c| c.norm_sqr()).collect()
    };
    let (pr, pt) = (power(reference), power(test));
    let centres = lsd_centres(fs);
    let bin_hz = fs / nfft as f64;
    let er: Vec<f64> = centres
        .iter()
        .map(|&f| 10.0 * (band_power(&pr, f, bin_hz) + 1e-300).log10())
        .collect();
    let et: Vec<f64> = centres
        .iter()
        .map(|&f| 10.0 * (band_power(&pt, f, bin_hz) + 1e-300).log10())
        .collect();
    let floor = er.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - LSD_FLOOR_DB;
    let ss: f64 = er
        .iter()
        .zip(&et)
        .map(|(r, t)| (r.max(floor) - t.max(floor)).powi(2))
        .sum();
    (ss / er.len() as f64).sqrt()
}

/// The [`LSD_BANDS`] ERB band centres of the error measures: 50 Hz … min(16 kHz, 0.45·fs).
fn lsd_centres(fs: f64) -> Vec<f64> {
    let mut centres = Vec::new();
    erb_centres(LSD_BANDS, 50.0, 16_000f64.min(0.45 * fs), &mut centres);
    centres
}

/// Power of the one-ERB-wide band around `fc` in a one-sided power spectrum with `bin_hz` bins.
fn band_power(p: &[f64], fc: f64, bin_hz: f64) -> f64 {
    let bw = erb_bandwidth_hz(fc);
    let a = ((fc - bw / 2.0) / bin_hz).floor().max(1.0) as usize;
    let b = (((fc + bw / 2.0) / bin_hz).ceil() as usize)
        .min(p.len() - 1)
        .max(a);
    p[a..=b].iter().sum()
}

/// Frame length of [`frame_erb_error_db`], samples at 48 kHz (85 ms; hop half of it).
pub const FRAME_ERROR_LEN: usize = 4096;

/// Playback level assumed by [`frame_erb_error_db`]: a full-scale sine plays at this SPL (the
/// level the default quality 60 assumes for its threshold-of-hearing culling).
pub const FRAME_ERROR_FULL_SCALE_DB_SPL: f64 = 110.0;

/// Time-resolved error: the worst frame's RMS over the ERB bands of the level difference, in dB.
/// Frames of [`FRAME_ERROR_LEN`] samples (Hann, hop half a frame); each band's level is its
/// mean-square in dB SPL with a full-scale sine at [`FRAME_ERROR_FULL_SCALE_DB_SPL`], floored at
/// the threshold of hearing at the band centre (`modal::hearing_threshold_db_spl`), so what
/// neither render makes audible counts as equal. Unlike [`erb_lsd_db`] over the whole render, a
/// tail cut while still above the threshold shows in its frames. No masking across bands is
/// modelled, so a weak component that a louder band would mask still counts: an upper bound of
/// the audible error.
pub fn frame_erb_error_db(reference: &[f64], test: &[f64], fs: f64) -> f64 {
    let n = reference.len().min(test.len());
    let len = FRAME_ERROR_LEN;
    if n < len {
        return 0.0;
    }
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(len);
    let window: Vec<f64> = (0..len)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / len as f64).cos())
        .collect();
    let w2: f64 = window.iter().map(|w| w * w).sum();
    let centres = lsd_centres(fs);
    let floors: Vec<f64> = centres
        .iter()
        .map(|&f| crate::engine::modal::hearing_threshold_db_spl(f))
        .collect();
    let bin_hz = fs / len as f64;
    let (mut buf, mut spec) = (fft.make_input_vec(), fft.make_output_vec());
    let mut levels = |x: &[f64]| -> Vec<f64> {
        for ((b, &v), w) in buf.iter_mut().zip(x).zip(&window) {
            *b = v * w;
        }
        fft.process(&mut buf, &mut spec).expect("fft sizes");
        let p: Vec<f64> = spec.iter().map(|c| c.norm_sqr()).collect();
        // One-sided bins: a component's mean-square is 2·Σ|X|² / (N·Σw²); a full-scale sine's is 1/2.
        centres
            .iter()
            .zip(&floors)
            .map(|(&f, &floor)| {
                let ms = 2.0 * band_power(&p, f, bin_hz) / (len as f64 * w2);
                (FRAME_ERROR_FULL_SCALE_DB_SPL + 10.0 * (ms / 0.5 + 1e-300).log10()).max(floor)
            })
            .collect()
    };
    let mut worst = 0.0f64;
    let mut start = 0;
    while start + len <= n {
        let r = levels(&reference[start..start + len]);
        let t = levels(&test[start..start + len]);
        let ss: f64 = r.iter().zip(&t).map(|(a, b)| (a - b).powi(2)).sum();
        worst = worst.max((ss / r.len() as f64).sqrt());
        start += len / 2;
    }
    worst
}

/// One measured point.
#[derive(Debug, Clone)]
pub struct Row {
    /// Scene name.
    pub scene: String,
    /// Lever and its value, e.g. `quality=60`.
    pub lever: String,
    /// Seconds of audio per second of wall time (min-of-N timing).
    pub rt_factor: f64,
    /// Wall ns per output sample.
    pub ns_per_sample: f64,
    /// Wall ns per computed mode-sample (NaN when none).
    pub ns_per_mode_sample: f64,
    /// Mode-samples computed.
    pub mode_samples: u64,
    /// SNR vs the reference, dB (NaN: not measured).
    pub snr_db: f64,
    /// ERB-band LSD vs the reference, dB.
    pub lsd_db: f64,
    /// Worst-frame ERB error vs the reference ([`frame_erb_error_db`]), dB; NaN if not measured.
    pub frame_err_db: f64,
}

impl Row {
    /// Percent of one core at real time.
    pub fn core_percent(&self) -> f64 {
        100.0 / self.rt_factor
    }
}

/// An engine scene: events at absolute sample times.
#[derive(Clone)]
struct EngineScene {
    name: &'static str,
    preset: Preset,
    voices: usize,
    len: usize,
    settings: Settings,
    /// (sample time, velocity, pitch factor)
    hits: Vec<(usize, f64, f64)>,
}

#[derive(Clone, Copy)]
struct Lever {
    quality_db: f64,
    block: usize,
    transient: bool,
    /// Mode culling on (static + dynamic); off (with `merging` off) is the unculled reference.
    culling: bool,
    /// Re-strike merging on (`Engine::set_merging_enabled`).
    merging: bool,
    /// Keep the output (for the error columns); off, the timed loop is the engine alone.
    record: bool,
}

fn run_engine(sc: &EngineScene, lv: Lever) -> (Vec<f64>, Stats, f64) {
    let mut e = Engine::new(&sc.preset, sc.voices, 7);
    e.prepare(FS, lv.block);
    e.set_transient_enabled(lv.transient);
    e.set_culling_enabled(lv.culling);
    e.set_merging_enabled(lv.merging);
    let mut s = sc.settings;
    s.quality_db = lv.quality_db;
    let mut l = vec![0.0f32; lv.block];
    let mut r = vec![0.0f32; lv.block];
    // f32 copy inside the timed loop (a memcpy); the f64 conversion happens after the timer.
    let mut out = Vec::<f32>::with_capacity(sc.len);
    let mut events = Vec::with_capacity(sc.hits.len());
    let mut hi = 0;
    e.take_stats();
    let t0 = CpuClock::now();
    let mut pos = 0;
    while pos < sc.len {
        let n = lv.block.min(sc.len - pos);
        events.clear();
        while hi < sc.hits.len() && sc.hits[hi].0 < pos + n {
            let (t, v, p) = sc.hits[hi];
            events.push(Event::Impact {
                offset: (t - pos) as u32,
                velocity_m_per_s: v,
                pitch_factor: p,
                key: -1,
            });
            hi += 1;
        }
        e.process(&s, &events, &mut l[..n], &mut r[..n]);
        if lv.record {
            out.extend_from_slice(&l[..n]);
        }
        pos += n;
    }
    let dt = t0.elapsed_secs();
    (out.iter().map(|&x| x as f64).collect(), e.take_stats(), dt)
}

fn timed_engine(sc: &EngineScene, lv: Lever, reps: usize) -> (Vec<f64>, Stats, f64) {
    let (out, stats, mut best) = run_engine(sc, lv);
    for _ in 1..reps {
        best = best.min(run_engine(sc, lv).2);
    }
    (out, stats, best)
}

fn row(scene: &str, lever: String, len: usize, secs: f64, mode_samples: u64, snr: f64, lsd: f64) -> Row {
    Row {
        scene: scene.to_string(),
        lever,
        rt_factor: len as f64 / FS / secs,
        ns_per_sample: secs * 1e9 / len as f64,
        ns_per_mode_sample: if mode_samples > 0 {
            secs * 1e9 / mode_samples as f64
        } else {
            f64::NAN
        },
        mode_samples,
        snr_db: snr,
        lsd_db: lsd,
        frame_err_db: f64::NAN,
    }
}

fn preset(name: &str) -> Preset {
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

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

fn scenes(quick: bool) -> Vec<EngineScene> {
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
    let chord_settings = Settings {
        damping: 0.05,
        quality_db: 300.0,
        ..Settings::default()
    };
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

const QUALITIES: [f64; 9] = [20.0, 25.0, 30.0, 40.0, 60.0, 80.0, 120.0, 200.0, 300.0];

/// Runs every engine scene and lever; returns rows.
fn engine_rows(quick: bool, reps: usize, keep: &dyn Fn(&str) -> bool, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
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
        let default_q = Settings::default().quality_db;
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

/// Bank-level rows: f32 SIMD kernels vs the f64 recursion, one impulse into 64 modes.
fn bank_rows(quick: bool, reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
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
    }
    rows
}

/// Scrape and roll through `SustainedVoice` + `ModalBank` (the engine integration is in progress).
fn sustained_rows(quick: bool, reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
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
    let mut rows = Vec::new();
    for kind in [ContactKind::Scrape, ContactKind::Roll] {
        let p = SustainedParams {
            kind,
            ..SustainedParams::default()
        };
        // `n_modes` = 0: the force generator alone (its cost does not depend on the object).
        let run = |n_modes: usize| {
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
            (out, t0.elapsed_secs())
        };
        for n_modes in [0, 24.min(modes.len()), modes.len()] {
            let name = format!("{kind:?}, {n_modes}-mode object");
            let mut secs = run(n_modes).1;
            for _ in 1..reps {
                secs = secs.min(run(n_modes).1);
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
    }
    rows
}

/// Measures the cost of what should be (almost) free against its active counterpart.
fn skip_rows(reps: usize, log: &mut dyn FnMut(&Row)) -> Vec<Row> {
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

/// Culling curve on the typical impact scenes: mode-samples and LSD per quality.
fn culling_rows(rows: &[Row]) -> String {
    let mut s = String::new();
    for scene in [
        "single impact (wood)",
        "single impact (metal)",
        "bouncing ball (wood)",
        "bouncing ball (metal)",
        "repeated strikes (4/s, metal)",
        "dense impacts (100/s, glass)",
    ] {
        let unculled = rows
            .iter()
            .find(|r| r.scene == scene && r.lever == "culling=off")
            .map_or(0, |r| r.mode_samples);
        for r in rows.iter().filter(|r| {
            r.scene == scene
                && (r.lever.starts_with("quality=") || r.lever == "culling=off" || r.lever == "merging only")
        }) {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.1}× | {:.2} | {:.1} |",
                scene,
                r.lever,
                r.mode_samples,
                unculled as f64 / r.mode_samples.max(1) as f64,
                r.lsd_db,
                r.frame_err_db
            );
        }
    }
    s
}

fn fmt(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "–".into()
    } else if v.is_infinite() {
        "∞".into()
    } else {
        format!("{v:.digits$}")
    }
}

fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| scene | lever | RT factor | % of one core | ns/sample | ns/mode-sample | mode-samples | SNR dB | ERB-LSD dB |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.scene,
            r.lever,
            fmt(r.rt_factor, 1),
            fmt(r.core_percent(), 3),
            fmt(r.ns_per_sample, 1),
            fmt(r.ns_per_mode_sample, 3),
            r.mode_samples,
            fmt(r.snr_db, 1),
            fmt(r.lsd_db, 3)
        );
    }
    s
}

fn machine() -> String {
    let lscpu = std::process::Command::new("lscpu")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    let pick = |key: &str| {
        lscpu
            .lines()
            .find(|l| l.starts_with(key))
            .map(|l| l[key.len()..].trim().to_string())
            .unwrap_or_else(|| "?".into())
    };
    let date = std::process::Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    format!(
        "- CPU: {} ({} CPUs)\n- Date: {}\n- Load average at start (1/5/15 min): {}\n- Kernel auto-detected: {:?}\n",
        pick("Model name:"),
        pick("CPU(s):"),
        date,
        load.split_whitespace().take(3).collect::<Vec<_>>().join(" "),
        Kernel::detect()
    )
}

fn plot(rows: &[Row], path: &Path) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let series: Vec<(&str, Vec<(f64, f64)>)> = [
        "single impact (wood)",
        "single impact (metal)",
        "bouncing ball (wood)",
        "repeated strikes (4/s, metal)",
        "dense impacts (100/s, glass)",
    ]
    .iter()
    .map(|&sc| {
        (
            sc,
            rows.iter()
                .filter(|r| r.scene == sc && r.lever.starts_with("quality="))
                .map(|r| (r.ns_per_sample, r.lsd_db.max(1e-3)))
                .collect(),
        )
    })
    .collect();
    let xmax = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.0))
        .fold(1.0, f64::max)
        * 1.1;
    let ymax = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .fold(0.1, f64::max)
        * 1.5;
    let mut chart = ChartBuilder::on(&root)
        .caption("Run time vs error (quality sweep)", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..xmax, (1e-3..ymax).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("wall ns per output sample (48 kHz, block 64)")
        .y_desc("ERB-band LSD vs unculled, dB")
        .draw()?;
    let colors = [RED, BLUE, MAGENTA, CYAN, GREEN];
    for ((name, pts), c) in series.into_iter().zip(colors) {
        chart
            .draw_series(LineSeries::new(pts.clone(), c))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
        chart.draw_series(PointSeries::of_element(pts, 4, c, &|p, s, st| {
            Circle::new(p, s, st.filled())
        }))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// Where `tactus bench` writes without `--update-docs` (a scratch folder cargo already ignores).
pub const DEFAULT_OUT: &str = "target/bench";

/// The committed results the README and docs/bench/README.md quote (`--update-docs`).
pub const DOCS_OUT: &str = "docs/bench";

/// Runs the benchmark, prints rows as they come, writes `results.md` and `time_vs_error.svg`
/// into `out_dir`.
pub fn run(quick: bool, out_dir: &Path, only: Option<&str>) -> anyhow::Result<()> {
    let reps = if quick { 1 } else { 3 };
    let header = machine();
    println!("{header}");
    let mut log = |r: &Row| {
        println!(
            "{:<45} {:<28} RT {:>8.1}x  {:>7.3}% core  {:>8.1} ns/smp  {:>7.3} ns/mode-smp  {:>11} mode-smp  SNR {:>6} dB  LSD {:>7} dB  frame {:>5} dB",
            r.scene,
            r.lever,
            r.rt_factor,
            r.core_percent(),
            r.ns_per_sample,
            r.ns_per_mode_sample,
            r.mode_samples,
            fmt(r.snr_db, 1),
            fmt(r.lsd_db, 3),
            fmt(r.frame_err_db, 1)
        )
    };
    if let Some(only) = only {
        let only = only.to_lowercase();
        let keep = |name: &str| name.to_lowercase().contains(&only);
        engine_rows(quick, reps, &keep, &mut log);
        if keep("bank 64 modes") {
            bank_rows(quick, reps, &mut log);
        }
        if keep("scrape") || keep("roll") {
            sustained_rows(quick, reps, &mut log);
        }
        if keep("idle") || keep("skip") {
            skip_rows(reps, &mut log);
        }
        return Ok(());
    }
    let engine = engine_rows(quick, reps, &|_| true, &mut log);
    let bank = bank_rows(quick, reps, &mut log);
    let sustained = sustained_rows(quick, reps, &mut log);
    let skip = skip_rows(reps, &mut log);
    std::fs::create_dir_all(out_dir)?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# Tactus benchmark results\n\nGenerated by `tactus bench{}` (release build).\n",
        if quick { " --quick" } else { "" }
    );
    md.push_str(&header);
    let _ = writeln!(
        md,
        "\nTiming: this thread's CPU time (not wall clock: other processes on the machine do not inflate it), min of {reps} run(s), 48 kHz, one thread. RT factor = seconds of audio per second of CPU time; \
         % of one core = 100 / RT factor. Error reference: engine scenes vs the same scene with nothing skipped (`Engine::set_culling_enabled(false)`, `Engine::set_merging_enabled(false)`), \
         block 64, transient on; bank rows vs the f64 recursion. ERB-LSD: {LSD_BANDS} ERB bands 50 Hz…16 kHz, band energies of the \
         whole render in dB floored {LSD_FLOOR_DB} dB below the loudest reference band, RMS of the dB difference.\n"
    );
    md.push_str("\n## Engine scenes\n\n");
    md.push_str(&table(&engine));
    md.push_str("\n## Bank: f32 kernels vs f64 reference\n\n");
    md.push_str(&table(&bank));
    md.push_str(
        "\n## Scrape and roll (SustainedVoice + ModalBank, 64-sample blocks, default speed and pressure)\n\n",
    );
    md.push_str(&table(&sustained));
    md.push_str(
        "\n## Culling curve\n\nWorst-frame error: the largest RMS over ERB bands of the level difference in one 85 ms \
         frame, levels in dB SPL with full scale at 110 dB SPL and floored at the threshold of hearing, no masking \
         across bands (`bench::frame_erb_error_db`): it shows tails cut while still audible in isolation, which the \
         whole-render ERB-LSD averages away.\n\n| scene | quality | mode-samples | saving vs no culling | ERB-LSD dB \
         | worst-frame error dB |\n|---|---|---:|---:|---:|---:|\n",
    );
    md.push_str(&culling_rows(&engine));
    md.push_str("\n## Skip what isn't needed\n\n");
    md.push_str(&table(&skip));
    let ns = |scene: &str, block: usize| {
        skip.iter()
            .find(|r| r.scene.starts_with(scene) && r.lever == format!("block {block}"))
            .map_or(f64::NAN, |r| r.ns_per_sample)
    };
    for block in [64, 512] {
        let (idle, ring, store, check) = (
            ns("idle engine", block),
            ns("one ringing 64-mode voice", block),
            ns("storing zeros", block),
            ns("checking clean outputs", block),
        );
        let _ = writeln!(
            md,
            "\n{block}-sample blocks: idle engine / one ringing 64-mode voice = {:.2} %; storing zeros to both outputs / \
             the same voice = {:.2} %; checking clean outputs / the same voice = {:.2} %; the idle engine's own work \
             beyond the check: {:.1} ns per block.",
            100.0 * idle / ring,
            100.0 * store / ring,
            100.0 * check / ring,
            (idle - check) * block as f64
        );
    }
    std::fs::write(out_dir.join("results.md"), md)?;
    plot(&engine, &out_dir.join("time_vs_error.svg"))?;
    println!("wrote {}", out_dir.join("results.md").display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(db_fs: f64, f: f64, n: usize) -> Vec<f64> {
        let a = 10f64.powf(db_fs / 20.0);
        (0..n)
            .map(|i| a * (2.0 * std::f64::consts::PI * f * i as f64 / FS).sin())
            .collect()
    }

    #[test]
    fn frame_error_sees_audible_cuts_only() {
        let n = 4 * FRAME_ERROR_LEN;
        let silence = vec![0.0; n];
        let loud = sine(-40.0, 1000.0, n);
        assert_eq!(frame_erb_error_db(&loud, &loud, FS), 0.0);
        // −40 dBFS at 110 dB SPL full scale = 70 dB SPL in one of 36 bands, against the 1 kHz
        // threshold (≈ 3.4 dB SPL): ≈ 66.6 / 6 = 11.1 dB RMS over the bands if the sine fell in one
        // band only. The Hann window's skirt reaches the neighbouring band too (measured: 11.8 dB),
        // so the error is at least the one-band figure and not much more.
        let e = frame_erb_error_db(&loud, &silence, FS);
        let thr = crate::engine::modal::hearing_threshold_db_spl(1000.0);
        let expect = (70.0 - thr) / (LSD_BANDS as f64).sqrt();
        assert!(e > expect - 0.1 && e < 1.15 * expect, "{e} vs {expect}");
        // Below the threshold of hearing (−120 dBFS = −10 dB SPL): cutting it costs nothing.
        let faint = sine(-120.0, 1000.0, n);
        assert_eq!(frame_erb_error_db(&faint, &silence, FS), 0.0);
        // A cut in the last frames only is seen in full (the whole-render LSD averages it).
        let mut tail_cut = loud.clone();
        tail_cut[n - FRAME_ERROR_LEN..].iter_mut().for_each(|v| *v = 0.0);
        assert!(frame_erb_error_db(&loud, &tail_cut, FS) > 0.9 * expect);
    }
}
