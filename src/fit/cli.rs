//! The `tactus fit` and `tactus preset show` commands: inputs expanded to files, files fitted in
//! parallel with a progress bar (the pipeline itself is [`crate::fit::pipeline`]), files that
//! cannot be fitted left out with their reason, and the preset, plots and summary written.

use crate::engine::object::spacing_octaves;
use crate::fit::family::FamilyBy;
use crate::fit::pipeline::{fit_file, FileResult};
use crate::preset::{ModeModel, Preset};
use crate::stats::median;
use std::path::{Path, PathBuf};

/// Expands files and folders (a folder's `.wav` files, sorted) into a file list; see
/// [`expand_inputs_noted`].
pub fn expand_inputs(inputs: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    expand_inputs_noted(inputs).map(|(files, _)| files)
}

/// Expands files and folders into the files to fit plus notes on what was skipped. A folder
/// contributes its `.wav` files (sorted); its other files are skipped with one note naming them.
/// A file named on the command line must be a WAV file (RIFF/WAVE header): anything else is an
/// error naming it, since fitting a README or a preset is a slip, not data.
pub fn expand_inputs_noted(inputs: &[PathBuf]) -> anyhow::Result<(Vec<PathBuf>, Vec<String>)> {
    let mut out = Vec::new();
    let mut notes = Vec::new();
    for p in inputs {
        if p.is_dir() {
            let mut entries: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| anyhow::anyhow!("{}: cannot read folder ({e})", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|q| q.is_file())
                .collect();
            entries.sort();
            let (wav, other): (Vec<PathBuf>, Vec<PathBuf>) = entries
                .into_iter()
                .partition(|q| q.extension().is_some_and(|x| x.eq_ignore_ascii_case("wav")));
            let other: Vec<String> = other
                .iter()
                .filter_map(|q| q.file_name().map(|n| n.to_string_lossy().into_owned()))
                .filter(|n| !n.starts_with('.'))
                .collect();
            if !other.is_empty() {
                notes.push(format!(
                    "{}: skipped {} non-WAV file{}: {}",
                    p.display(),
                    other.len(),
                    if other.len() == 1 { "" } else { "s" },
                    other.join(", ")
                ));
            }
            if wav.is_empty() {
                notes.push(format!("{}: no .wav files in the folder", p.display()));
            }
            out.extend(wav);
        } else if p.is_file() {
            if !has_wav_header(p) {
                anyhow::bail!(
                    "{}: not a WAV file (no RIFF/WAVE header); tactus fit reads WAV recordings or folders of them",
                    p.display()
                );
            }
            out.push(p.clone());
        } else if p.exists() {
            anyhow::bail!("{}: not a file or folder", p.display());
        } else {
            anyhow::bail!("{}: no such file or folder", p.display());
        }
    }
    Ok((out, notes))
}

/// Whether `p` starts with a RIFF (or RF64) … WAVE header.
fn has_wav_header(p: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 12];
    std::fs::File::open(p)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && (head.starts_with(b"RIFF") || head.starts_with(b"RF64"))
        && head[8..].starts_with(b"WAVE")
}

/// A recording left out of a fit, with the reason in words.
#[derive(Debug, Clone, PartialEq)]
pub struct LeftOut {
    /// File name.
    pub name: String,
    /// Why it was left out.
    pub reason: String,
}

/// What [`fit_inputs`] produced.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// The recordings fitted, in input order.
    pub results: Vec<FileResult>,
    /// The recordings left out, in input order.
    pub left_out: Vec<LeftOut>,
    /// Notes on skipped inputs (non-WAV files in folders).
    pub notes: Vec<String>,
    /// The pooled preset.
    pub preset: Preset,
}

/// Why a fit stopped early ([`FitObserver::cancelled`]).
pub const CANCELLED: &str = "fit cancelled";

fn short_name(p: &str) -> String {
    Path::new(p)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.to_owned())
}

/// Fits the files of `inputs` in parallel (one rayon task per file; results kept in input order,
/// so the preset is byte-identical to a sequential fit) and pools them into a preset. A file that
/// cannot be fitted is left out with its reason unless `strict`; so is a file without which an
/// invalid pooled preset becomes valid. `progress` shows a bar with ETA on stderr.
pub fn fit_inputs(
    inputs: &[PathBuf],
    material: &str,
    count: usize,
    strict: bool,
    progress: bool,
) -> anyhow::Result<FitOutcome> {
    let pooling = Pooling {
        material,
        name: None,
        family_by: FamilyBy::Auto,
        count,
        dense: false,
    };
    fit_grouped(inputs, pooling, strict, progress)
}

/// Modes per sampled object when none is asked for (`tactus fit --modes`).
pub const DEFAULT_COUNT: usize = 24;

/// How fitted recordings are pooled into a preset: the material, the display name, how the
/// recordings are grouped into families, and the modes per object.
#[derive(Debug, Clone, Copy)]
pub struct Pooling<'a> {
    /// Material class, e.g. wood.
    pub material: &'a str,
    /// Display name (default: the material, capitalised).
    pub name: Option<&'a str>,
    /// Family grouping of the recordings.
    pub family_by: FamilyBy,
    /// Modes per sampled object.
    pub count: usize,
    /// Fit a dense mode field to each dense recording (`tactus fit --dense`).
    pub dense: bool,
}

impl Pooling<'_> {
    /// The preset pooled from `results`, grouped into families by the recordings' paths.
    fn build(&self, results: &[FileResult]) -> anyhow::Result<Preset> {
        self.build_with_contact(results, crate::engine::force::HC_DEFAULT_EXPONENT)
    }

    fn build_with_contact(&self, results: &[FileResult], exponent: f64) -> anyhow::Result<Preset> {
        let paths: Vec<PathBuf> = results.iter().map(|r| PathBuf::from(&r.name)).collect();
        let families = crate::fit::family::families_of(&paths, self.family_by)?;
        let objects = crate::fit::family::objects_of(&paths)?;
        crate::fit::pipeline::build_family_preset_with_contact(
            self.material,
            self.name,
            results,
            families.as_deref(),
            self.count,
            Some(&objects),
            exponent,
            self.dense,
        )
    }

    /// `preset` with its contact exponent fitted to the velocity layers among `results`
    /// ([`crate::fit::velocity`]); unchanged when they hold no object with two layers.
    fn with_fitted_contact(
        &self,
        preset: Preset,
        results: &[FileResult],
        observer: &dyn FitObserver,
    ) -> anyhow::Result<Preset> {
        let paths: Vec<PathBuf> = results.iter().map(|r| PathBuf::from(&r.name)).collect();
        let objects = crate::fit::velocity::layered_objects(&paths)?;
        if objects.is_empty() || observer.cancelled() {
            return Ok(preset);
        }
        observer.stage(&format!(
            "fitting the contact exponent to {} objects with velocity layers",
            objects.len()
        ));
        let Some(fit) = crate::fit::velocity::fit_exponent(&preset, &objects)? else {
            return Ok(preset);
        };
        let mut p = self.build_with_contact(results, fit.exponent)?;
        p.provenance.notes.push_str(&format!(
            " Contact exponent {} fitted to {} objects with velocity layers: their median hardest/softest-layer centroid ratio is {:.3}, the draws' {:.3} (struck at the speeds the plugin plays those layers at).",
            fit.exponent, fit.objects, fit.recorded_ratio, fit.drawn_ratio
        ));
        Ok(p)
    }
}

/// The preset `pooling` makes of fitted `results`: pooled, family-balanced, and with its
/// contact exponent fitted to the velocity layers among them. For callers that fit files once
/// and pool several subsets of them (`tactus eval --leave-family-out`).
pub fn pool(pooling: &Pooling, results: &[FileResult], observer: &dyn FitObserver) -> anyhow::Result<Preset> {
    let preset = pooling.build(results)?;
    pooling.with_fitted_contact(preset, results, observer)
}

/// Watches (and may stop) a fit while its files are fitted: `tactus fit`'s progress bar, the
/// plugin editor's progress display and its cancel.
pub trait FitObserver: Sync {
    /// Called once the inputs are expanded, with the number of files to fit.
    fn started(&self, _files: usize) {}
    /// Called after each file (in completion order, from the fitting threads).
    fn file_done(&self) {}
    /// Polled before each file; true makes the fit stop with an error instead of fitting the
    /// remaining files.
    fn cancelled(&self) -> bool {
        false
    }
    /// Called when the fit enters a stage after the files (e.g. the contact exponent's fit),
    /// with a line saying what it does.
    fn stage(&self, _what: &str) {}
}

/// An observer that neither shows nor stops anything.
pub struct Silent;

impl FitObserver for Silent {}

/// The terminal progress bar of `tactus fit` (hidden when `visible` is false).
struct Bar {
    bar: indicatif::ProgressBar,
}

impl FitObserver for Bar {
    fn started(&self, files: usize) {
        self.bar.set_length(files as u64);
    }
    fn file_done(&self) {
        self.bar.inc(1);
    }
    fn stage(&self, what: &str) {
        if self.bar.is_hidden() {
            eprintln!("{what}");
        } else {
            self.bar.println(what);
        }
    }
}

/// As [`fit_inputs`], with the pooling spelled out (`tactus fit`'s `--family-by` and `--name`).
pub fn fit_grouped(
    inputs: &[PathBuf],
    pooling: Pooling,
    strict: bool,
    progress: bool,
) -> anyhow::Result<FitOutcome> {
    let bar = indicatif::ProgressBar::new(0);
    if progress {
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "fitting {bar:40} {pos}/{len} elapsed {elapsed} eta {eta}",
            )
            .expect("valid template"),
        );
    } else {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let bar = Bar { bar };
    let outcome = fit_observed(inputs, pooling, strict, &bar);
    bar.bar.finish_and_clear();
    outcome
}

/// As [`fit_grouped`], reporting progress to (and stopping on request of) `observer`.
pub fn fit_observed(
    inputs: &[PathBuf],
    pooling: Pooling,
    strict: bool,
    observer: &dyn FitObserver,
) -> anyhow::Result<FitOutcome> {
    use rayon::prelude::*;
    let material = pooling.material;
    if material.trim().is_empty() {
        anyhow::bail!("--material must not be empty");
    }
    let (files, notes) = expand_inputs_noted(inputs)?;
    if files.is_empty() {
        anyhow::bail!("no WAV recordings found in the inputs ({})", notes.join("; "));
    }
    observer.started(files.len());
    let fitted: Vec<Result<FileResult, LeftOut>> = files
        .par_iter()
        .map(|f| {
            if observer.cancelled() {
                return Err(LeftOut {
                    name: short_name(&f.display().to_string()),
                    reason: CANCELLED.into(),
                });
            }
            // A panic in one file's fit must not throw away the others' minutes of work.
            let r =
                std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| fit_file(f))).unwrap_or_else(|p| {
                    let msg = p
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| p.downcast_ref::<String>().cloned())
                        .unwrap_or_default();
                    Err(anyhow::anyhow!(
                        "{}: internal error while fitting ({msg})",
                        f.display()
                    ))
                });
            observer.file_done();
            r.map_err(|e| LeftOut {
                name: short_name(&f.display().to_string()),
                reason: format!("{e:#}").replace(&format!("{}: ", f.display()), ""),
            })
        })
        .collect();
    if observer.cancelled() {
        anyhow::bail!("{CANCELLED}");
    }
    let (mut results, mut left_out) = (Vec::new(), Vec::new());
    for r in fitted {
        match r {
            Ok(r) => results.push(r),
            Err(l) => left_out.push(l),
        }
    }
    let listing = |l: &[LeftOut]| {
        l.iter()
            .map(|l| format!("{}: {}", l.name, l.reason))
            .collect::<Vec<_>>()
            .join("; ")
    };
    if strict && !left_out.is_empty() {
        anyhow::bail!(
            "{} of {} recordings cannot be fitted (--strict): {}",
            left_out.len(),
            files.len(),
            listing(&left_out)
        );
    }
    // One recording is enough: a family may have a single recording (the variance floors of
    // `distribution::fit_modes` then set its spread).
    if results.is_empty() {
        anyhow::bail!(
            "no recording could be fitted, so there is nothing to pool{}",
            if left_out.is_empty() {
                String::new()
            } else {
                format!(" (left out: {})", listing(&left_out))
            }
        );
    }
    let preset = match pooling.build(&results) {
        Ok(p) => p,
        Err(e) => {
            let culprits = culprits(&pooling, &results);
            if culprits.is_empty() || strict || results.len() == culprits.len() {
                anyhow::bail!("{}", explain_build_error(&e, &results, &culprits));
            }
            let reason = format!(
                "with it the pooled preset is invalid ({}), without it the preset is valid",
                plain_reason(&e)
            );
            let mut kept = Vec::new();
            for (i, r) in results.into_iter().enumerate() {
                if culprits.contains(&i) {
                    left_out.push(LeftOut {
                        name: short_name(&r.name),
                        reason: reason.clone(),
                    });
                } else {
                    kept.push(r);
                }
            }
            results = kept;
            pooling
                .build(&results)
                .map_err(|e| anyhow::anyhow!("{}", explain_build_error(&e, &results, &[])))?
        }
    };
    let preset = pooling.with_fitted_contact(preset, &results, observer)?;
    Ok(FitOutcome {
        results,
        left_out,
        notes,
        preset,
    })
}

/// Indices of the recordings without which `build_preset` succeeds (each tried alone).
fn culprits(pooling: &Pooling, results: &[FileResult]) -> Vec<usize> {
    use rayon::prelude::*;
    (0..results.len())
        .into_par_iter()
        .filter(|&i| {
            let rest: Vec<FileResult> = results
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, r)| r.clone())
                .collect();
            pooling.build(&rest).is_ok()
        })
        .collect()
}

/// What a pooling/validation error means, in words (the internal field stays in parentheses
/// for bug reports).
fn plain_reason(e: &anyhow::Error) -> String {
    let text = format!("{e:#}");
    let part = if text.contains("modes.") {
        "the mode distribution (frequencies, levels, decays) holds an impossible value"
    } else if text.contains("transient") {
        "the strike-noise (transient) distribution holds an impossible value"
    } else if text.contains("damping") {
        "the damping law fitted to the modes' decays is impossible"
    } else {
        return text;
    };
    format!("{part}; internal check: {text}")
}

fn explain_build_error(e: &anyhow::Error, results: &[FileResult], culprits: &[usize]) -> String {
    let names: Vec<String> = culprits.iter().map(|&i| short_name(&results[i].name)).collect();
    if names.is_empty() {
        format!(
            "cannot pool the {} fitted recordings into a preset: {}; no single recording is responsible (leaving out any one does not help)",
            results.len(),
            plain_reason(e)
        )
    } else {
        format!(
            "cannot pool the {} fitted recordings into a preset: {}; the preset is valid without {}",
            results.len(),
            plain_reason(e),
            names.join(", ")
        )
    }
}

/// `tactus fit`.
pub fn run_fit(
    inputs: &[PathBuf],
    material: &str,
    output: &Path,
    count: usize,
    plot: Option<&Path>,
    family_by: FamilyBy,
    name: Option<&str>,
    strict: bool,
    dense: bool,
) -> anyhow::Result<()> {
    use std::io::IsTerminal;
    // Fail on an impossible output before minutes of fitting (without leaving an empty file
    // behind if the fit then fails).
    let parent = output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if output.is_dir() || !parent.is_dir() {
        anyhow::bail!(
            "cannot write {}: {}",
            output.display(),
            if output.is_dir() {
                "it is a folder"
            } else {
                "its folder does not exist"
            }
        );
    }
    let t0 = std::time::Instant::now();
    let FitOutcome {
        results,
        left_out,
        notes,
        preset,
    } = fit_grouped(
        inputs,
        Pooling {
            material,
            name,
            family_by,
            count,
            dense,
        },
        strict,
        std::io::stderr().is_terminal(),
    )?;
    for n in &notes {
        eprintln!("note: {n}");
    }
    println!(
        "{:<64} {:>6} {:>9} {:>10}",
        "file", "modes", "attack ms", "ERB LSD dB"
    );
    for r in &results {
        println!(
            "{:<64} {:>6} {:>9.2} {:>10.2} {}",
            short_name(&r.name),
            r.modes.len(),
            1e3 * r.attack_s,
            r.distance_db,
            r.note
        );
    }
    for l in &left_out {
        println!("{:<64} left out: {}", l.name, l.reason);
    }
    let d: Vec<f64> = results.iter().map(|r| r.distance_db).collect();
    println!("median ERB-band log-spectral distance: {:.2} dB", median(&d));
    println!(
        "{} recording{} fitted, {} left out{} in {:.1} s",
        results.len(),
        if results.len() == 1 { "" } else { "s" },
        left_out.len(),
        if left_out.is_empty() {
            String::new()
        } else {
            format!(
                " ({})",
                left_out
                    .iter()
                    .map(|l| l.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        t0.elapsed().as_secs_f64()
    );
    std::fs::write(output, crate::fit::pipeline::fitted_preset_json(&preset) + "\n")
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", output.display()))?;
    eprintln!("wrote {}", output.display());
    if let Some(dir) = plot {
        let files = crate::fit::plot::write_plots(dir, &results, &preset)?;
        eprintln!("wrote {} plots into {}", files.len(), dir.display());
    }
    Ok(())
}

/// `tactus preset show`. Output written to a locked stdout; a closed pipe (`| head`) ends the
/// listing successfully instead of panicking.
pub fn run_show(path: &Path) -> anyhow::Result<()> {
    let p = Preset::load(path)?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match write_show(&mut out, &p).and_then(|()| std::io::Write::flush(&mut out)) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r.map_err(|e| anyhow::anyhow!("cannot write to stdout: {e}")),
    }
}

/// The `preset show` listing of `p` into `out`.
pub fn write_show(out: &mut dyn std::io::Write, p: &Preset) -> std::io::Result<()> {
    writeln!(
        out,
        "{} ({}, {:?}), format {}",
        p.name, p.material_class, p.origin, p.format_version
    )?;
    writeln!(out, "method: {}", p.provenance.method)?;
    writeln!(
        out,
        "sources: {} ({} {})",
        p.provenance.sources.len(),
        p.provenance.date,
        p.provenance.tool_version
    )?;
    match &p.modes {
        ModeModel::Fixed { modes } => {
            writeln!(out, "fixed modes: {}", modes.len())?;
            for m in modes {
                writeln!(
                    out,
                    "  {:9.1} Hz {:7.1} dB {:8.1} dB/s",
                    m.freq_hz, m.level_db, m.decay_db_per_s
                )?;
            }
        }
        ModeModel::Distribution(d) => {
            let m = d.count;
            let g = &d.gaussian;
            writeln!(
                out,
                "mode distribution: {m} modes, mean spacing {:.3} octaves (measured {:.3} on the means)",
                d.mean_spacing_octaves,
                spacing_octaves((0..m).map(|i| g.mean[2 * m + i].exp2()))
            )?;
            writeln!(
                out,
                "  {:>4} {:>9} {:>6} {:>8} {:>6} {:>9} {:>6}",
                "rank", "Hz", "sd oct", "level dB", "sd", "dB/s", "sd ln"
            )?;
            for i in 0..m {
                writeln!(
                    out,
                    "  {:>4} {:>9.1} {:>6.3} {:>8.1} {:>6.1} {:>9.1} {:>6.2}",
                    i,
                    g.mean[2 * m + i].exp2(),
                    g.covariance[2 * m + i][2 * m + i].sqrt(),
                    g.mean[i],
                    g.covariance[i][i].sqrt(),
                    match (d.decay, &p.damping) {
                        (crate::preset::DecayCoordinates::DampingResidual, Some(law)) => {
                            law.residual_base_db_per_s(g.mean[2 * m + i].exp2()) * g.mean[m + i].exp()
                        }
                        _ => g.mean[m + i].exp(),
                    },
                    g.covariance[m + i][m + i].sqrt()
                )?;
            }
        }
    }
    if let Some(t) = &p.transient {
        let n = t.bands;
        let lv = &t.gaussian.mean[..n];
        writeln!(
            out,
            "transient: {n} bands {:.0}..{:.0} Hz, level {:.1}..{:.1} dB, decay {:.0}..{:.0} dB/s",
            t.low_hz,
            t.high_hz,
            lv.iter().cloned().fold(f64::INFINITY, f64::min),
            lv.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            t.gaussian.mean[n..]
                .iter()
                .map(|v| v.exp())
                .fold(f64::INFINITY, f64::min),
            t.gaussian.mean[n..]
                .iter()
                .map(|v| v.exp())
                .fold(f64::NEG_INFINITY, f64::max)
        )?;
    }
    if let Some(d) = &p.damping {
        writeln!(
                out,
            "damping: alpha1 {:.3} 1/s, alpha2 {:.3e} s, alpha3 {:.3}, sigma {:.3}, eta {:.4}; 1 kHz decay {:.1} dB/s",
            d.alpha1,
            d.alpha2,
            d.alpha3,
            d.sigma,
            d.eta,
            d.decay_db_per_s(1000.0)
        )?;
    }
    for f in &p.families {
        let modes = match &f.modes {
            ModeModel::Distribution(d) => format!(
                "{} modes {:.0}..{:.0} Hz",
                d.count,
                d.gaussian.mean[2 * d.count].exp2(),
                d.gaussian.mean[3 * d.count - 1].exp2()
            ),
            ModeModel::Fixed { modes } => format!("{} fixed modes", modes.len()),
        };
        let law = f
            .damping
            .map(|d| format!(", 1 kHz decay {:.1} dB/s", d.decay_db_per_s(1000.0)))
            .unwrap_or_default();
        writeln!(out, "family {}: weight {}, {modes}{law}", f.name, f.weight)?;
    }
    writeln!(out, "contact stiffness: {:.3e} N/m", p.contact_stiffness_n_per_m)?;
    Ok(())
}
