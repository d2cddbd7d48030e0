//! Fitting a material from recordings inside the plugin: what the editor's "Fit recordings…"
//! button and files dropped on the editor start. GUI-free, so the editor and the tests drive
//! the same path (`tests/integration/plugin_fit.rs`).
//!
//! A [`FitJob`] runs `tactus fit`'s pipeline ([`crate::fit::run::fit_files`]) on a thread of
//! its own, with a rayon pool of its own (never the audio thread, never the host's GUI thread).
//! Progress reaches the GUI through atomics and the result through a [`OnceLock`] written once,
//! so the GUI reads both without locking. On success the job stores the fitted preset's JSON in
//! the user preset slot ([`UserPresetSlot::set_json`]): the audio thread receives it exactly as
//! a loaded preset file (a mailbox it only `try_lock`s, a sampler swap without allocation), and
//! the JSON is saved with the project. A failed or cancelled fit changes nothing, so the current
//! material keeps playing; its reason is the job's result.
//!
//! [`UserPresetSlot::set_json`]: super::user_preset::UserPresetSlot::set_json

use super::params::TactusParams;
use crate::fit::error::FitError;
use crate::fit::pool::Pooling;
use crate::fit::run::{fit_files, LeftOut};
use crate::preset::{Origin, Preset};
use crate::work::{catch_panic, Observer};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;
use std::time::Instant;

/// Material classes offered for a fit (the class sets the default contact stiffness a fitted
/// preset starts from, see `fit::pool::preset::assemble`).
pub const MATERIAL_CLASSES: [&str; 8] = [
    "wood",
    "metal",
    "glass",
    "ceramic",
    "plastic",
    "stone",
    "cardboard",
    "other",
];

/// Modes per object of a fit started in the plugin (`tactus fit`'s default).
pub const DEFAULT_FIT_MODES: usize = 24;

/// What a fit makes of its recordings.
#[derive(Debug, Clone, PartialEq)]
pub struct FitSettings {
    /// Material class, one of [`MATERIAL_CLASSES`].
    pub material_class: String,
    /// Modes per sampled object.
    pub modes: usize,
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            material_class: "wood".into(),
            modes: DEFAULT_FIT_MODES,
        }
    }
}

/// A finished, successful fit.
#[derive(Debug, Clone)]
pub struct FitReport {
    /// Display name of the fitted preset.
    pub preset_name: String,
    /// File names of the recordings fitted, in input order.
    pub fitted: Vec<String>,
    /// Recordings left out, with the reason.
    pub left_out: Vec<LeftOut>,
    /// Notes on skipped inputs (files in a folder that are not recordings).
    pub notes: Vec<String>,
    /// The preset JSON now in the user preset slot.
    pub json: String,
    /// Wall time of the fit, s.
    pub seconds: f64,
}

struct Shared {
    /// Files fitted so far and files to fit (0 until the inputs are expanded).
    done: AtomicUsize,
    total: AtomicUsize,
    cancel: AtomicBool,
    /// Set once, by the fitting thread, when it is done.
    result: OnceLock<Result<FitReport, String>>,
}

/// The editor's adapter: the fit panel reads the counts, its Cancel button sets `cancel`.
impl Observer for Shared {
    fn started(&self, files: u64) {
        self.total.store(files as usize, Ordering::Release);
    }
    fn advanced(&self, what: &str, steps: u64) {
        if what == "file" {
            self.done.fetch_add(steps as usize, Ordering::AcqRel);
        }
    }
    fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Acquire)
    }
}

/// One fit in progress (or finished). Dropping it cancels the fit and waits for the files being
/// fitted at that moment (the thread runs code of the plugin's library, which a host may unload
/// after the editor is gone).
pub struct FitJob {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    inputs: Vec<PathBuf>,
}

impl FitJob {
    /// Starts fitting `inputs` (recordings and folders of them) into a material for `params`'s
    /// user preset slot.
    pub fn start(params: Arc<TactusParams>, inputs: Vec<PathBuf>, settings: FitSettings) -> Self {
        let shared = Arc::new(Shared {
            done: AtomicUsize::new(0),
            total: AtomicUsize::new(0),
            cancel: AtomicBool::new(false),
            result: OnceLock::new(),
        });
        let worker = shared.clone();
        let files = inputs.clone();
        let thread = std::thread::Builder::new()
            .name("tactus-fit".into())
            .spawn(move || {
                let result = catch_panic(|| run(&params, &files, &settings, &worker)).unwrap_or_else(|_| {
                    Err("internal error while fitting (a panic); nothing changed".into())
                });
                let _ = worker.result.set(result);
            });
        let thread = match thread {
            Ok(t) => Some(t),
            Err(e) => {
                let _ = shared
                    .result
                    .set(Err(format!("cannot start the fitting thread: {e}")));
                None
            }
        };
        Self {
            shared,
            thread,
            inputs,
        }
    }

    /// Files fitted so far and files to fit (0 while the inputs are being listed).
    pub fn progress(&self) -> (usize, usize) {
        (
            self.shared.done.load(Ordering::Acquire),
            self.shared.total.load(Ordering::Acquire),
        )
    }

    /// The outcome once the fit is over: the report, or why nothing changed.
    pub fn result(&self) -> Option<&Result<FitReport, String>> {
        self.shared.result.get()
    }

    /// Whether the fit is over.
    pub fn finished(&self) -> bool {
        self.result().is_some()
    }

    /// Asks the fit to stop before its next file; its result is then an error and nothing
    /// changes.
    pub fn cancel(&self) {
        self.shared.cancel.store(true, Ordering::Release);
    }

    /// What was asked to be fitted.
    pub fn inputs(&self) -> &[PathBuf] {
        &self.inputs
    }

    /// Waits for the fit to end and returns its outcome (tests, command-line use).
    pub fn wait(mut self) -> Result<FitReport, String> {
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
        self.shared
            .result
            .get()
            .cloned()
            .unwrap_or_else(|| Err("the fitting thread ended without a result".into()))
    }
}

impl Drop for FitJob {
    fn drop(&mut self) {
        self.cancel();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Threads of a fit's pool: one core is left to the host's audio and GUI threads.
fn fit_threads() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .saturating_sub(1)
        .max(1)
}

/// The fitting thread: fit, check, install.
fn run(
    params: &TactusParams,
    inputs: &[PathBuf],
    settings: &FitSettings,
    shared: &Shared,
) -> Result<FitReport, String> {
    let t0 = Instant::now();
    if inputs.is_empty() {
        return Err("nothing to fit: no files or folders given".into());
    }
    let pooling = Pooling::new(&settings.material_class).modes(settings.modes);
    // A scoped pool: its threads are joined before this function returns, so none outlives the
    // job (see `FitJob`'s drop).
    let outcome = rayon::ThreadPoolBuilder::new()
        .num_threads(fit_threads())
        .thread_name(|i| format!("tactus-fit-{i}"))
        .build_scoped(
            |t| t.run(),
            |pool| pool.install(|| fit_files(inputs, &pooling, false, shared)),
        )
        .map_err(|e| format!("cannot start the fitting threads: {e}"))?
        .map_err(|e| {
            if FitError::is_cancelled(&e) {
                FitError::Cancelled.to_string()
            } else {
                format!("fit failed, the current material keeps playing: {e:#}")
            }
        })?;
    let json = crate::fit::pool::preset::fitted_preset_json(&outcome.preset);
    // The slot falls back to a built-in material on JSON it cannot read; a fit must never do
    // that, so the text is checked before it goes in.
    let preset = Preset::from_json(&json, None).map_err(|e| {
        format!("fit failed, the current material keeps playing: the fitted preset does not read back ({e})")
    })?;
    if shared.cancelled() {
        return Err(FitError::Cancelled.to_string());
    }
    params
        .user_preset
        .set_json(json.clone())
        .map_err(|e| format!("fit failed, the current material keeps playing: {e}"))?;
    Ok(FitReport {
        preset_name: preset.name,
        fitted: outcome.results.iter().map(|r| file_name(&r.name)).collect(),
        left_out: outcome.left_out,
        notes: outcome.notes,
        json,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

fn file_name(p: &str) -> String {
    Path::new(p)
        .file_name()
        .map_or_else(|| p.to_owned(), |n| n.to_string_lossy().into_owned())
}

/// What a set of dropped (or picked) paths asks for.
#[derive(Debug, Clone, PartialEq)]
pub enum DropAction {
    /// A preset file: load it into the user slot.
    LoadPreset(PathBuf),
    /// Recordings and folders of them: fit a material.
    Fit(Vec<PathBuf>),
    /// Nothing usable; the reason.
    Reject(String),
}

/// Sorts dropped paths: a single `.json` file is a preset to load, unless it is a mode table
/// ([`crate::fit::table::is_table_path`]); otherwise every folder and every other file goes to
/// the fit (which names any file that is neither a recording nor a mode table), except preset
/// files mixed into recordings, which are rejected as a slip.
pub fn classify_drop(paths: &[PathBuf]) -> DropAction {
    let is_json = |p: &Path| {
        p.extension().is_some_and(|x| x.eq_ignore_ascii_case("json")) && !crate::fit::table::is_table_path(p)
    };
    match paths {
        [] => DropAction::Reject("nothing was dropped".into()),
        [one] if is_json(one) => DropAction::LoadPreset(one.clone()),
        _ => {
            if let Some(j) = paths.iter().find(|p| is_json(p)) {
                return DropAction::Reject(format!(
                    "{}: a preset file among recordings; drop a preset on its own to load it, or only recordings and folders to fit",
                    j.display()
                ));
            }
            DropAction::Fit(paths.to_vec())
        }
    }
}

/// Where a material came from, in words for the editor.
#[derive(Debug, Clone, PartialEq)]
pub struct ProvenanceSummary {
    /// "fitted", "measured", "derived" or "provisional".
    pub origin: &'static str,
    /// Its sources: recordings for a fitted preset, publications for a derived one.
    pub sources: Vec<String>,
    /// Date and tool version, e.g. "2026-11-25, tactus 0.1.0".
    pub made: String,
}

/// The provenance of `preset` as the editor shows it.
pub fn provenance_summary(preset: &Preset) -> ProvenanceSummary {
    let p = &preset.provenance;
    let made = match (p.date.is_empty(), p.tool_version.is_empty()) {
        (false, false) => format!("{}, tactus {}", p.date, p.tool_version),
        (false, true) => p.date.clone(),
        (true, false) => format!("tactus {}", p.tool_version),
        (true, true) => String::new(),
    };
    ProvenanceSummary {
        origin: match preset.origin {
            Origin::Fitted => "fitted",
            Origin::Derived => "derived",
            Origin::Measured => "measured",
            Origin::Provisional => "provisional",
        },
        sources: p.sources.clone(),
        made,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn drops_sort_into_preset_fit_or_reject() {
        let p = |s: &str| PathBuf::from(s);
        assert_eq!(
            classify_drop(&[p("/a/Wood.JSON")]),
            DropAction::LoadPreset(p("/a/Wood.JSON"))
        );
        assert_eq!(
            classify_drop(&[p("/a/x.wav"), p("/a/y.FLAC"), p("/a/dir")]),
            DropAction::Fit(vec![p("/a/x.wav"), p("/a/y.FLAC"), p("/a/dir")])
        );
        assert_eq!(classify_drop(&[p("/a/dir")]), DropAction::Fit(vec![p("/a/dir")]));
        assert!(matches!(
            classify_drop(&[p("/a/x.wav"), p("/a/y.json")]),
            DropAction::Reject(r) if r.contains("y.json")
        ));
        assert!(matches!(classify_drop(&[]), DropAction::Reject(_)));
    }

    #[test]
    fn provenance_of_shipped_presets() {
        let wood = crate::engine::materials::builtin_presets().remove(0);
        let s = provenance_summary(&wood);
        assert_eq!(s.origin, "fitted");
        assert!(s.sources.iter().any(|f| f.ends_with(".wav")), "{:?}", s.sources);
        let glass = crate::engine::materials::builtin_presets().remove(2);
        assert_ne!(provenance_summary(&glass).origin, "fitted");
    }
}
