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
//!
//! Files: `metrics.rs` (error measures), `scenes.rs` (engine, bank and scrape/roll rows),
//! `skip.rs` (costs that should be near zero: idle engine and plugin, zeroing, worst-case object
//! draw), `report.rs` (tables, culling curve, plot).

use crate::engine::dsp::scales::erb_centres;
use crate::engine::materials::{builtin_presets, derived, DerivedSpec};
use crate::engine::modal::{Kernel, ModalBank, ModeParams};
use crate::engine::reference::{render_modes_f64_recursive, snr_db};
use crate::engine::sustained::{ContactKind, SurfaceKind, SustainedParams, SustainedVoice};
use crate::engine::{Engine, Event, Settings, Stats};
use crate::preset::Preset;
use std::fmt::Write as _;
use std::path::Path;

/// Default settings with the given decay multiplier and culling threshold: the two levers the
/// ringing and culling rows set.
fn settings_with(damping: f64, quality_db: f64) -> Settings {
    let mut s = Settings::default();
    s.impact.damping = damping;
    s.output.quality_db = quality_db;
    s
}

mod dense;
mod gestures;
mod metrics;
mod report;
mod scenes;
mod skip;

pub use dense::dense_preset;
use dense::dense_rows;
use gestures::gesture_rows;
pub use metrics::*;
use report::*;
pub use scenes::preset64;
use scenes::*;
use skip::*;

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

/// Where `tactus bench` writes without `--update-docs` (a scratch folder cargo already ignores).
pub const DEFAULT_OUT: &str = "target/bench";

/// The committed results the README and docs/bench/README.md quote (`--update-docs`).
pub const DOCS_OUT: &str = "docs/bench";

/// The rows whose scene name contains `only` (lowercase), printed by `log`, nothing written.
fn run_only(quick: bool, reps: usize, only: &str, log: &mut dyn FnMut(&Row)) {
    let only = only.to_lowercase();
    let keep = |name: &str| name.to_lowercase().contains(&only);
    engine_rows(quick, reps, &keep, log);
    if keep(STEREO_CHORD) {
        stereo_rows(quick, reps, log);
    }
    if keep("bank 64 modes") {
        bank_rows(quick, reps, log);
    }
    sustained_rows(quick, reps, &keep, log);
    if keep("idle") || keep("skip") {
        skip_rows(reps, log);
    } else {
        if keep("zero") {
            zeroing_rows(480_000, 4 * reps.max(25), log);
        }
        if keep("plugin") {
            plugin_idle_rows(480_000, 4 * reps.max(25), log);
        }
    }
    if keep("draw") || keep("object") {
        draw_rows(reps, log);
    }
    if keep("dense") || keep("512") {
        dense_rows(quick, reps, log);
    }
    if keep("gesture") || keep("bounce") || keep("break") || keep("rattle") {
        gesture_rows(reps, log);
    }
}

/// The skip section's ratios: per block size, the idle engine, the output check and the idle
/// plugin against one ringing voice, and the cost of storing zeros.
fn skip_summary(skip: &[Row]) -> String {
    let mut md = String::new();
    let ns = |scene: &str, block: usize| {
        skip.iter()
            .find(|r| r.scene.starts_with(scene) && r.lever == format!("block {block}"))
            .map_or(f64::NAN, |r| r.ns_per_sample)
    };
    for block in [64, 512] {
        let (idle, ring, check) = (
            ns("idle engine", block),
            ns("one ringing 64-mode voice", block),
            ns("checking clean outputs", block),
        );
        let _ = write!(
            md,
            "\n{block}-sample blocks: idle engine / one ringing 64-mode voice = {:.2} %; checking clean outputs / the \
             same voice = {:.2} %; the idle engine's own work beyond the check: {:.1} ns per block",
            100.0 * idle / ring,
            100.0 * check / ring,
            (idle - check) * block as f64
        );
        if block == 64 {
            let _ = write!(
                md,
                "; idle plugin (its own `process`) / the same voice = {:.2} % (target ≤ 1 %)",
                100.0 * ns("idle plugin", block) / ring
            );
        }
        let _ = writeln!(md, ".");
        for r in skip
            .iter()
            .filter(|r| r.scene.starts_with("storing zeros") && r.lever == format!("block {block}"))
        {
            let _ = writeln!(
                md,
                "- {}: {:.1} ns per block, {:.2} % of the voice",
                r.scene,
                r.ns_per_sample * block as f64,
                100.0 * r.ns_per_sample / ring
            );
        }
    }
    md
}

/// Runs the benchmark, prints rows as they come, writes `results.md` and `time_vs_error.svg`
/// into `out_dir`.
pub fn run(quick: bool, out_dir: &Path, only: Option<&str>) -> anyhow::Result<()> {
    let reps = if quick { 1 } else { 3 };
    let header = machine();
    println!("{header}");
    let mut log = |r: &Row| {
        println!(
            "{:<45} {:<28} RT {:>8.1}x  {:>7.3}% core  {:>8.1} ns/smp  {:>7} ns/mode-smp  {:>11} mode-smp  SNR {:>6} dB  LSD {:>7} dB  frame {:>5} dB",
            r.scene,
            r.lever,
            r.rt_factor,
            r.core_percent(),
            r.ns_per_sample,
            fmt(r.ns_per_mode_sample, 3),
            r.mode_samples,
            fmt(r.snr_db, 1),
            fmt(r.lsd_db, 3),
            fmt(r.frame_err_db, 1)
        )
    };
    if let Some(only) = only {
        run_only(quick, reps, only, &mut log);
        return Ok(());
    }
    let engine = engine_rows(quick, reps, &|_| true, &mut log);
    let (stereo, stereo_ratios) = stereo_rows(quick, reps, &mut log);
    let bank = bank_rows(quick, reps, &mut log);
    let sustained = sustained_rows(quick, reps, &|_| true, &mut log);
    let skip = skip_rows(reps, &mut log);
    let draws = draw_rows(reps, &mut log);
    let dense = dense_rows(quick, reps, &mut log);
    let gestures = gesture_rows(reps, &mut log);
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
    md.push_str(
        "\n## Stereo against mono\n\nThe 64-voice chord at width 0 (mono kernels) and at the plugin's default width \
         (stereo kernels), rendered in alternating turns of 2 048 samples (about a millisecond) so both see the \
         same machine, at least 5 times each; each row's time is its fastest render, the ratio that of the summed \
         times; error columns: the stereo fold-down (L + R)/2 against the mono render.\n\n",
    );
    md.push_str(&table(&stereo));
    for (q, ratio) in &stereo_ratios {
        let _ = writeln!(
            md,
            "\nStereo/mono chord CPU time at quality={q}: {ratio:.3} (target ≤ 1.05)."
        );
    }
    md.push_str("\n## Bank: f32 kernels vs f64 reference\n\n");
    md.push_str(&table(&bank));
    md.push_str(
        "\n## Scrape and roll (SustainedVoice + ModalBank, 64-sample blocks, default speed and pressure; a measured surface's row gives its CPU time over the synthetic 64-mode row's, target ≤ 1.10)\n\n",
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
    md.push_str(&skip_summary(&skip));
    md.push_str(
        "\n## Drawing a new object (worst case)\n\nTime of one `ObjectSampler::sample`, max over 16 seeds; \
         % core is relative to one 64-sample block at 48 kHz, the budget a draw on the audio thread takes.\n\n",
    );
    md.push_str(&table(&draws));
    md.push_str(
        "\n## Dense objects\n\nA 64-mode distribution with a dense mode field filling the engine's mode limit \
         (`bench::dense_preset`), one hit, 16 voices at once at default settings (error columns against the full \
         bank, nothing skipped) and a 64-voice chord, 64-sample blocks, transient on; the bank alone with one impulse; the worst-case draw (`preset::worst_case_preset`, % core relative to one 64-sample block).\n\n",
    );
    md.push_str(&table(&dense));
    md.push_str("\n## Gestures\n\nThe scene renderer on each gesture's example scene (docs/model.md §11), fragment and rattling-object draws included.\n\n");
    md.push_str(&table(&gestures));
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
