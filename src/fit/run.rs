//! Many recordings fitted into one preset: inputs expanded to files, files fitted in parallel
//! ([`crate::fit::recording::fit_file`]), files that cannot be fitted left out with their reason,
//! the rest pooled ([`Pooling`]). What `tactus fit`, the Python module's `fit` and the plugin
//! editor's fit all run.

use crate::analysis::audio;
use crate::fit::error::FitError;
use crate::fit::pool::Pooling;
use crate::fit::recording::FileResult;
use crate::preset::Preset;
use crate::work::Observer;
use std::path::{Path, PathBuf};

/// Expands files and folders into the files to fit plus notes on what was skipped. A folder
/// contributes its recordings (sorted; named as [`audio::EXTENSIONS`] lists: WAV, FLAC, AIFF,
/// Ogg, MP3); its other files are skipped with one note naming them. A file named on the command
/// line must be a recording by its header or its name ([`audio::Container::of_file`]): anything
/// else is an error naming it, since fitting a README or a preset is a slip, not data.
pub fn expand_inputs(inputs: &[PathBuf]) -> anyhow::Result<(Vec<PathBuf>, Vec<String>)> {
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
            let (recordings, other): (Vec<PathBuf>, Vec<PathBuf>) = entries
                .into_iter()
                .partition(|q| audio::has_recording_extension(q));
            let other: Vec<String> = other
                .iter()
                .filter_map(|q| q.file_name().map(|n| n.to_string_lossy().into_owned()))
                .filter(|n| !n.starts_with('.'))
                .collect();
            if !other.is_empty() {
                notes.push(format!(
                    "{}: skipped {} file{} that are not recordings: {}",
                    p.display(),
                    other.len(),
                    if other.len() == 1 { "" } else { "s" },
                    other.join(", ")
                ));
            }
            if recordings.is_empty() {
                notes.push(format!(
                    "{}: no recordings ({}) in the folder",
                    p.display(),
                    audio::FORMATS
                ));
            }
            out.extend(recordings);
        } else if p.is_file() {
            if audio::Container::of_file(p).is_none() {
                anyhow::bail!(
                    "{}: not a recording (no {} header or name); tactus fit reads such recordings, folders of them, or mode tables (.csv, or .json with a \"cf\" array; docs/measured.md)",
                    p.display(),
                    audio::FORMATS
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

/// A recording left out of a fit, with the reason in words.
#[derive(Debug, Clone, PartialEq)]
pub struct LeftOut {
    /// File name.
    pub name: String,
    /// Why it was left out.
    pub reason: String,
}

/// Fits the recording at `path` ([`crate::fit::recording::fit_file`], with what a dense mode
/// field needs when `dense`) with a panic caught as [`FitError::Panicked`]; errors name the file.
pub fn fit_file_guarded(path: &std::path::Path, dense: bool) -> anyhow::Result<FileResult> {
    crate::work::catch_panic(|| crate::fit::recording::fit_file(path, dense)).unwrap_or_else(|msg| {
        Err(anyhow::Error::new(FitError::Panicked(msg)).context(path.display().to_string()))
    })
}

/// What [`fit_files`] produced.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// The recordings fitted, in input order.
    pub results: Vec<FileResult>,
    /// The recordings left out, in input order.
    pub left_out: Vec<LeftOut>,
    /// Notes on skipped inputs (files in folders that are not recordings).
    pub notes: Vec<String>,
    /// The pooled preset.
    pub preset: Preset,
}

/// The file name of a path written as text.
pub fn short_name(p: &str) -> String {
    Path::new(p)
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.to_owned())
}

/// Pools the mode tables `inputs` ([`crate::fit::table`]) as [`fit_files`] pools recordings,
/// keeping the first `objects_per_table` objects of each table when given (PyImpact draws
/// from the first). Nothing is left out: a table that cannot be read is an error naming it.
pub fn fit_tables(
    inputs: &[PathBuf],
    pooling: &Pooling,
    objects_per_table: Option<usize>,
    observer: &dyn Observer,
) -> anyhow::Result<FitOutcome> {
    observer.started(inputs.len() as u64);
    let mut tables = crate::fit::table::read_all(inputs)?;
    if let Some(n) = objects_per_table {
        tables = tables.into_iter().map(|t| t.first_objects(n)).collect();
    }
    observer.advanced("file", inputs.len() as u64);
    let pooled = crate::fit::table::pool(&tables, pooling)?;
    Ok(FitOutcome {
        results: pooled.results,
        left_out: Vec::new(),
        notes: pooled.notes,
        preset: pooled.preset,
    })
}

/// Whether `inputs` are mode tables (every one, [`crate::fit::table::is_table_path`]); an
/// error when tables and recordings are mixed, since one preset pools one kind of input.
pub fn inputs_are_tables(inputs: &[PathBuf]) -> anyhow::Result<bool> {
    let tables: Vec<&PathBuf> = inputs
        .iter()
        .filter(|p| p.is_file() && crate::fit::table::is_table_path(p))
        .collect();
    if tables.is_empty() {
        return Ok(false);
    }
    if let Some(other) = inputs.iter().find(|p| !tables.contains(p)) {
        anyhow::bail!(
            "{}: mode tables and recordings in one fit ({} is a mode table); fit them separately",
            other.display(),
            tables[0].display()
        );
    }
    Ok(true)
}

/// Fits the files of `inputs` (recordings and folders of them, [`expand_inputs`]; or mode
/// tables, [`fit_tables`]) in parallel (one rayon task per file; results kept in input order, so the preset is
/// byte-identical to a sequential fit) and pools them into a preset as `pooling` says. A file
/// that cannot be fitted is left out with its reason unless `strict`; so is a file without which
/// an invalid pooled preset becomes valid. `observer` hears the file count, each file done and
/// the later stages, and may stop the fit ([`FitError::Cancelled`]).
pub fn fit_files(
    inputs: &[PathBuf],
    pooling: &Pooling,
    strict: bool,
    observer: &dyn Observer,
) -> anyhow::Result<FitOutcome> {
    use rayon::prelude::*;
    let material = pooling.material.as_str();
    if material.trim().is_empty() {
        anyhow::bail!("--material must not be empty");
    }
    if inputs_are_tables(inputs)? {
        return fit_tables(inputs, pooling, None, observer);
    }
    let (files, notes) = expand_inputs(inputs)?;
    if files.is_empty() {
        anyhow::bail!("no recordings found in the inputs ({})", notes.join("; "));
    }
    observer.started(files.len() as u64);
    let fitted: Vec<Result<FileResult, LeftOut>> = files
        .par_iter()
        .map(|f| {
            if observer.cancelled() {
                return Err(LeftOut {
                    name: short_name(&f.display().to_string()),
                    reason: FitError::Cancelled.to_string(),
                });
            }
            let r = fit_file_guarded(f, pooling.dense);
            observer.advanced("file", 1);
            r.map_err(|e| LeftOut {
                name: short_name(&f.display().to_string()),
                reason: format!("{e:#}").replace(&format!("{}: ", f.display()), ""),
            })
        })
        .collect();
    if observer.cancelled() {
        return Err(FitError::Cancelled.into());
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
    let preset = match pooling.assemble_default(&results) {
        Ok(p) => p,
        Err(e) => {
            let culprits = culprits(pooling, &results);
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
                .assemble_default(&results)
                .map_err(|e| anyhow::anyhow!("{}", explain_build_error(&e, &results, &[])))?
        }
    };
    let preset = pooling.fit_contact(preset, &results, observer)?;
    Ok(FitOutcome {
        results,
        left_out,
        notes,
        preset,
    })
}

/// Indices of the recordings without which the pooling succeeds (each tried alone).
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
            pooling.assemble_default(&rest).is_ok()
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

/// Why a fitted preset could not be written to `output`, checked before minutes of fitting:
/// `Some("it is a folder")` or `Some("its folder does not exist")`; `None` when it can be tried.
pub fn unwritable(output: &Path) -> Option<&'static str> {
    let parent = output
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    if output.is_dir() {
        Some("it is a folder")
    } else if !parent.is_dir() {
        Some("its folder does not exist")
    } else {
        None
    }
}
