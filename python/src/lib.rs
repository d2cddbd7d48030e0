//! The `tactus` Python module: the CLI's render, batch and fit, and the evaluation's features,
//! called in-process. Every call validates its input with the library's own checks, so errors
//! carry the CLI's one-line messages; long calls run on a worker thread with the GIL released
//! while the calling thread watches for Ctrl-C.

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyPermissionError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict, PyTuple};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::time::Duration;
use tactus::batch::{self as tbatch, Batch, Shard};
use tactus::engine::limiter::Limiter;
use tactus::scene::{self, LoadedScene, Scene};
use tactus::fit::pool::family::FamilyBy;
use tactus::fit::pool::Pooling;
use tactus::wav::{WavFormat, WavHeader};
use tactus::work::{catch_panic, Observer};

/// How often the calling thread checks for Ctrl-C while a worker runs.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// The Python exception for a library error: `OSError` (its `FileNotFoundError` or
/// `PermissionError` subclass where the kind is known) when the error comes from the file
/// system or names a path of the call that does not exist, `ValueError` otherwise. The message
/// is the CLI's (`{:#}`: the context chain on one line).
fn to_py(e: &anyhow::Error, paths: &[PathBuf]) -> PyErr {
    let msg = format!("{e:#}");
    if let Some(io) = e.chain().find_map(|c| c.downcast_ref::<std::io::Error>()) {
        return match io.kind() {
            std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(msg),
            std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(msg),
            _ => PyOSError::new_err(msg),
        };
    }
    if paths.iter().any(|p| !p.exists()) {
        return PyFileNotFoundError::new_err(msg);
    }
    PyValueError::new_err(msg)
}

/// The module's [`Observer`]: a progress bar on stderr when it is a terminal, and Ctrl-C (seen
/// by [`run_blocking`] on the calling thread) as a stop.
struct Progress {
    cancel: Arc<AtomicBool>,
    bar: Option<indicatif::ProgressBar>,
}

impl Progress {
    /// A stop flag (shared with [`run_blocking`]) and, on a terminal, a bar drawn with
    /// `template` (indicatif's).
    fn new(template: &str) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(indicatif::ProgressStyle::with_template(template).expect("valid template"));
            b
        });
        Self {
            cancel: Arc::new(AtomicBool::new(false)),
            bar,
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

impl Observer for Progress {
    fn started(&self, total: u64) {
        if let Some(b) = &self.bar {
            b.set_length(total);
        }
    }
    fn advanced(&self, _what: &str, steps: u64) {
        if let Some(b) = &self.bar {
            b.inc(steps);
        }
    }
    fn stage(&self, what: &str) {
        match &self.bar {
            Some(b) => b.println(what),
            None => eprintln!("{what}"),
        }
    }
    fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// What Ctrl-C does to work run by [`run_blocking`]: either way the work's stop flag is set;
/// then the call waits for the work to stop, or raises at once and leaves the work to stop in
/// the background.
enum OnInterrupt {
    Wait,
    RaiseAtOnce,
}

/// Runs `work` on a worker thread with the GIL released, checking for signals (Ctrl-C) on the
/// calling thread meanwhile. On a signal, `cancel` is set and, as `on_interrupt` says, the
/// worker's stop awaited or not, then the signal's exception (KeyboardInterrupt) is raised. A
/// panic in `work` becomes a RuntimeError: no panic crosses into Python.
fn run_blocking<T: Send + 'static>(
    py: Python<'_>,
    cancel: Arc<AtomicBool>,
    on_interrupt: OnInterrupt,
    work: impl FnOnce() -> anyhow::Result<T> + Send + 'static,
) -> PyResult<anyhow::Result<T>> {
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .name("tactus".into())
        .spawn(move || {
            let _ = tx.send(catch_panic(work));
        })
        .map_err(|e| PyRuntimeError::new_err(format!("cannot start a worker thread: {e}")))?;
    py.detach(move || {
        let mut interrupted: Option<PyErr> = None;
        loop {
            match rx.recv_timeout(SIGNAL_POLL) {
                Ok(r) => {
                    if let Some(e) = interrupted {
                        return Err(e);
                    }
                    return r.map_err(|p| PyRuntimeError::new_err(format!("internal error in tactus: {p}")));
                }
                Err(RecvTimeoutError::Timeout) => {
                    if interrupted.is_some() {
                        continue;
                    }
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        cancel.store(true, Ordering::Relaxed);
                        match on_interrupt {
                            OnInterrupt::Wait => interrupted = Some(e),
                            OnInterrupt::RaiseAtOnce => return Err(e),
                        }
                    }
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(PyRuntimeError::new_err(
                        "internal error in tactus: the worker thread ended without a result",
                    ))
                }
            }
        }
    })
}

/// JSON text of a dict-like Python value (`json.dumps`); a value JSON cannot hold is a
/// ValueError naming `what`.
fn dumps(py: Python<'_>, value: &Bound<'_, PyAny>, what: &str) -> PyResult<String> {
    py.import("json")?
        .call_method1("dumps", (value,))
        .and_then(|s| s.extract::<String>())
        .map_err(|e| PyValueError::new_err(format!("{what}: not JSON-serialisable ({e})")))
}

/// Where a scene or spec given to the module comes from.
enum Source {
    /// JSON text (a dict dumped, or a JSON string); the label names it in errors.
    Text(String, &'static str),
    /// A file.
    Path(PathBuf),
}

/// A dict, a JSON string (starting with `{`) or a path (str or os.PathLike).
fn source_of(py: Python<'_>, value: &Bound<'_, PyAny>, what: &str) -> PyResult<Source> {
    if value.is_instance_of::<PyDict>() {
        return Ok(Source::Text(dumps(py, value, what)?, "(dict)"));
    }
    if let Ok(s) = value.extract::<String>() {
        if s.trim_start().starts_with('{') {
            return Ok(Source::Text(s, "(string)"));
        }
    }
    if let Ok(p) = value.extract::<PathBuf>() {
        return Ok(Source::Path(p));
    }
    if value.hasattr("keys")? {
        // Any other mapping: as a dict.
        return Ok(Source::Text(dumps(py, value, what)?, "(mapping)"));
    }
    Err(PyValueError::new_err(format!(
        "{what} must be a dict, a JSON string or a path, got {}",
        value.get_type().name()?
    )))
}

fn check_block(block: usize) -> PyResult<()> {
    tbatch::check_block(block).map_err(|e| PyValueError::new_err(format!("block {e}")))
}

/// A float32 NumPy array of shape (frames, 2) from the two channels, written once into a
/// bytearray (so the array is writable) and viewed by NumPy without a further copy.
fn stereo_array<'py>(py: Python<'py>, l: &[f32], r: &[f32]) -> PyResult<Bound<'py, PyAny>> {
    let frames = l.len().min(r.len());
    let bytes = PyByteArray::new_with(py, frames * 8, |buf| {
        for (i, (a, b)) in l.iter().zip(r).enumerate() {
            buf[8 * i..8 * i + 4].copy_from_slice(&a.to_ne_bytes());
            buf[8 * i + 4..8 * i + 8].copy_from_slice(&b.to_ne_bytes());
        }
        Ok(())
    })?;
    let np = py.import("numpy")?;
    np.call_method1("frombuffer", (bytes, np.getattr("float32")?))?
        .call_method1("reshape", (frames, 2))
}

/// Renders a scene to stereo audio, as `tactus render` does.
///
/// Args:
///     scene: a scene as a dict, a JSON string, or the path of a scene file (the format of
///         `tactus render`; relative `preset_file` paths resolve against the scene file's
///         folder, or the working directory for a dict or string).
///     stems: also return each object's own render.
///     block: processing block size in samples, 1..=8192 (the CLI's `--block`, default 256).
///     limit: pass the mix through the plugin's output limiter (the CLI's `--limit`): no
///         sample above -0.3 dBFS, material under it unchanged. Default off: the unlimited
///         float render, as data sets want it. Stems are never limited.
///
/// Returns:
///     `(audio, sample_rate)`: `audio` a float32 array of shape (frames, 2), sample for sample
///     what `tactus render --format float32` writes (with `--limit` when `limit=True`). With `stems=True`,
///     `(audio, sample_rate, stems)`, `stems` a dict from object name to its (frames, 2) array
///     (a one-object scene's object is named "object", as the CLI's stem file).
///
/// Raises:
///     ValueError: an invalid scene (the CLI's one-line message).
///     OSError: a scene file that cannot be read.
///     KeyboardInterrupt: Ctrl-C (the render stops at its next block).
#[pyfunction]
#[pyo3(signature = (scene, stems = false, *, block = 256, limit = false))]
fn render<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    stems: bool,
    block: usize,
    limit: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    check_block(block)?;
    let source = source_of(py, scene, "scene")?;
    let paths: Vec<PathBuf> = match &source {
        Source::Path(p) => vec![p.clone()],
        Source::Text(..) => Vec::new(),
    };
    let loaded: LoadedScene = match &source {
        Source::Text(t, _) => Scene::parse(t, None),
        Source::Path(p) => Scene::load(p),
    }
    .map_err(|e| to_py(&e, &paths))?;
    let progress = Progress::new("rendering {bar:40} {percent:>3}% eta {eta}");
    let sr = loaded.scene.sample_rate;
    let out = run_blocking(py, progress.cancel.clone(), OnInterrupt::Wait, move || {
        let mut objects: Vec<(String, Vec<f32>, Vec<f32>)> = Vec::new();
        let mix = scene::render_objects(
            &loaded,
            block,
            &progress,
            |name, l, r| {
                if stems {
                    let name = if name.is_empty() { "object" } else { name };
                    objects.push((name.to_string(), l.to_vec(), r.to_vec()));
                }
                Ok(())
            },
        );
        progress.finish();
        mix.map(|(mut l, mut r)| {
            if limit {
                Limiter::new(sr as f64).process_stereo(&mut l, &mut r);
            }
            ((l, r), objects)
        })
    })?;
    let ((l, r), objects) = out.map_err(|e| to_py(&e, &paths))?;
    let audio = stereo_array(py, &l, &r)?;
    if stems {
        let d = PyDict::new(py);
        for (name, l, r) in &objects {
            d.set_item(name, stereo_array(py, l, r)?)?;
        }
        PyTuple::new(py, [audio, sr.into_pyobject(py)?.into_any(), d.into_any()])
    } else {
        PyTuple::new(py, [audio, sr.into_pyobject(py)?.into_any()])
    }
}

fn wav_format(s: &str) -> PyResult<WavFormat> {
    match s.to_ascii_lowercase().as_str() {
        "pcm16" => Ok(WavFormat::Pcm16),
        "pcm24" => Ok(WavFormat::Pcm24),
        "float32" => Ok(WavFormat::Float32),
        _ => Err(PyValueError::new_err(format!(
            "format must be pcm16, pcm24 or float32, got '{s}'"
        ))),
    }
}

fn wav_header(s: &str) -> PyResult<WavHeader> {
    match s.to_ascii_lowercase().as_str() {
        "plain" => Ok(WavHeader::Plain),
        "extensible" => Ok(WavHeader::Extensible),
        _ => Err(PyValueError::new_err(format!(
            "wav_header must be plain or extensible, got '{s}'"
        ))),
    }
}

/// A shard as "I/N" or (I, N), checked by the CLI's parser.
fn shard_of(value: Option<&Bound<'_, PyAny>>) -> PyResult<Shard> {
    let Some(v) = value else {
        return Ok(Shard::ALL);
    };
    let text = if let Ok((i, n)) = v.extract::<(i64, i64)>() {
        format!("{i}/{n}")
    } else if let Ok(s) = v.extract::<String>() {
        s
    } else {
        return Err(PyValueError::new_err(format!(
            "shard must be \"I/N\" or a tuple (I, N), got {}",
            v.get_type().name()?
        )));
    };
    text.parse::<Shard>().map_err(PyValueError::new_err)
}

/// Renders variations of a scene into a folder of WAV files with a manifest, as
/// `tactus batch` does (docs/batch.md): parallel, resumable (files already there are skipped),
/// shardable.
///
/// Args:
///     spec: a variation spec as a dict, a JSON string or the path of a spec file; a path
///         ending in `.jsonl` is a JSON-lines file of scenes (the CLI's `--scenes`). A spec's
///         relative scene and preset paths resolve against the spec file's folder, or the
///         working directory for a dict or string.
///     out_dir: output folder (created if missing).
///     threads: worker threads (default: one per core).
///     shard: render only the items i with i % N == I, given as "I/N" or (I, N); the
///         manifest is then manifest-shard-I-of-N.{jsonl,csv} (merge with
///         `tactus merge-manifests`).
///     format: "pcm16", "pcm24" (default) or "float32".
///     wav_header: "plain" (default) or "extensible".
///     block: processing block size in samples, 1..=8192 (default 256).
///     limit: pass each render through the plugin's output limiter (the CLI's `--limit`;
///         default off, the unlimited render).
///
/// Returns:
///     dict with `rendered` and `skipped` (files already there) item counts of this shard and
///     `manifest`, the path of its manifest .jsonl.
///
/// Raises:
///     ValueError: an invalid spec or scene (the CLI's one-line message).
///     OSError: a file that cannot be read or written.
///     KeyboardInterrupt: Ctrl-C (items not yet started are left out; finished files stay,
///         so a rerun resumes; no manifest is written).
#[pyfunction]
#[pyo3(signature = (spec, out_dir, threads = None, shard = None, *, format = "pcm24", wav_header = "plain", block = 256, limit = false))]
fn batch<'py>(
    py: Python<'py>,
    spec: &Bound<'py, PyAny>,
    out_dir: PathBuf,
    threads: Option<usize>,
    shard: Option<&Bound<'py, PyAny>>,
    format: &str,
    wav_header: &str,
    block: usize,
    limit: bool,
) -> PyResult<Bound<'py, PyDict>> {
    check_block(block)?;
    let out = tbatch::Output {
        format: self::wav_format(format)?,
        header: self::wav_header(wav_header)?,
        block,
        limit,
    };
    let shard = shard_of(shard)?;
    let source = source_of(py, spec, "spec")?;
    let mut paths = Vec::new();
    let b = match &source {
        Source::Text(t, label) => Batch::from_spec_text(t, label, None, out),
        Source::Path(p) => {
            paths.push(p.clone());
            if p.extension().is_some_and(|x| x.eq_ignore_ascii_case("jsonl")) {
                Batch::from_lines(p, out)
            } else {
                Batch::from_spec(p, out)
            }
        }
    }
    .map_err(|e| to_py(&e, &paths))?;
    let progress = Progress::new("{pos}/{len} {bar:40} {percent:>3}% eta {eta}");
    let dir = out_dir.clone();
    let summary = run_blocking(py, progress.cancel.clone(), OnInterrupt::Wait, move || {
        let s = tbatch::run(&b, &dir, out, shard, threads, &progress);
        progress.finish();
        s
    })?
    .map_err(|e| to_py(&e, &paths))?;
    let stem = tbatch::manifest_stem(shard);
    let d = PyDict::new(py);
    d.set_item("rendered", summary.rendered)?;
    d.set_item("skipped", summary.skipped)?;
    d.set_item("manifest", out_dir.join(format!("{stem}.jsonl")))?;
    Ok(d)
}

/// Fits a material preset from recordings or measured mode tables, as `tactus fit` does.
///
/// Args:
///     paths: a recording (WAV, FLAC, AIFF, Ogg Vorbis or MP3) or folder of them, or a list
///         of such paths (one material); or mode tables of one material (`.json` as PyImpact's,
///         `.csv`/`.txt` lines `object,frequency_hz,level_db,t60_s`; docs/measured.md), not
///         mixed with recordings.
///     material: material class, e.g. "wood".
///     name: display name of the preset (default: the material, capitalised).
///     out: also write the preset JSON to this file (what `tactus fit -o` writes).
///     modes: modes per sampled object, 2..=64 (default 24).
///     family_by: how recordings are grouped into object families: "auto" (default),
///         "manifest", "name", "folder" or "none" (the CLI's `--family-by`).
///     strict: raise when any recording cannot be fitted (default: leave it out with a
///         UserWarning saying why).
///
/// Returns:
///     the preset as a dict (the JSON of the preset file).
///
/// Raises:
///     ValueError: nothing could be fitted, or an invalid argument (the CLI's message).
///     OSError: a missing input or an unwritable `out`.
///     KeyboardInterrupt: Ctrl-C (raised at once; files already being fitted finish in the
///         background, the others are not started, and all is discarded).
#[pyfunction]
#[pyo3(signature = (paths, material, name = None, out = None, *, modes = 24, family_by = "auto", strict = false))]
fn fit<'py>(
    py: Python<'py>,
    paths: &Bound<'py, PyAny>,
    material: String,
    name: Option<String>,
    out: Option<PathBuf>,
    modes: i64,
    family_by: &str,
    strict: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let inputs: Vec<PathBuf> = match paths.extract::<PathBuf>() {
        Ok(p) => vec![p],
        Err(_) => paths.extract::<Vec<PathBuf>>().map_err(|_| {
            PyValueError::new_err("paths must be a path or a list of paths (str or os.PathLike)")
        })?,
    };
    if !(2..=64).contains(&modes) {
        return Err(PyValueError::new_err(format!(
            "modes must be in 2..=64, got {modes}"
        )));
    }
    let family_by: FamilyBy = family_by.parse().map_err(PyValueError::new_err)?;
    if let Some(o) = &out {
        // As the CLI: fail on an impossible output before minutes of fitting.
        if let Some(why) = tactus::fit::run::unwritable(o) {
            let msg = format!("cannot write {}: {why}", o.display());
            return Err(if o.is_dir() {
                PyOSError::new_err(msg)
            } else {
                PyFileNotFoundError::new_err(msg)
            });
        }
    }
    let mut pooling = Pooling::new(&material).family_by(family_by).modes(modes as usize);
    if let Some(n) = &name {
        pooling = pooling.named(n);
    }
    let files = inputs.clone();
    let progress = Progress::new("fitting {bar:40} {pos}/{len} elapsed {elapsed} eta {eta}");
    let outcome = run_blocking(py, progress.cancel.clone(), OnInterrupt::RaiseAtOnce, move || {
        let o = tactus::fit::run::fit_files(&files, &pooling, strict, &progress);
        progress.finish();
        o
    })?
    .map_err(|e| to_py(&e, &inputs))?;
    let warn = |text: String| -> PyResult<()> {
        let warnings = py.import("warnings")?;
        warnings.call_method1("warn", (text,)).map(|_| ())
    };
    for n in &outcome.notes {
        warn(n.clone())?;
    }
    for l in &outcome.left_out {
        warn(format!("{} left out: {}", l.name, l.reason))?;
    }
    let text = tactus::fit::pool::preset::fitted_preset_json(&outcome.preset);
    if let Some(o) = &out {
        std::fs::write(o, text.clone() + "\n").map_err(|e| {
            to_py(
                &anyhow::Error::new(e).context(format!("cannot write {}", o.display())),
                &[],
            )
        })?;
    }
    py.import("json")?.call_method1("loads", (text,))
}

/// The names of the built-in materials (what a scene's `material` accepts, case-insensitive).
#[pyfunction]
fn materials() -> Vec<String> {
    tactus::engine::materials::shipped_presets()
        .into_iter()
        .map(|p| p.name)
        .collect()
}

/// The names of the surfaces a scrape or roll event's `surface` accepts: `synthetic` (its RMS
/// height set by `roughness`), then the twelve measured ones (docs/model.md §6).
#[pyfunction]
fn surfaces() -> Vec<String> {
    tactus::engine::sustained::SurfaceKind::ALL
        .iter()
        .map(|k| k.name().to_string())
        .collect()
}

/// The features `tactus eval` measures on recordings and renders (docs/evaluation.md), of any
/// signal: spectral centroid, loss factor, T60, decay slope, attack share, early decay time,
/// spectral peak count.
///
/// Args:
///     audio: samples as a 1-D array (mono) or a 2-D array of shape (frames, channels),
///         mixed to mono by the mean of the channels as `tactus eval` mixes recordings and
///         renders; any scale.
///     sample_rate: in Hz.
///
/// Returns:
///     dict from feature name (centroid_hz, tan_phi, t60_s, decay_slope, attack_share, edt_s,
///     peak_count) to its value.
///
/// Raises:
///     ValueError: a signal without these features (silent, too few decaying partials, ...)
///         or of the wrong shape, the reason in words.
#[pyfunction]
fn features<'py>(
    py: Python<'py>,
    audio: &Bound<'py, PyAny>,
    sample_rate: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let np = py.import("numpy")?;
    let a = np
        .call_method1("asarray", (audio, np.getattr("float64")?))
        .map_err(|e| PyValueError::new_err(format!("audio: not an array of numbers ({e})")))?;
    let shape: Vec<usize> = a.getattr("shape")?.extract()?;
    let channels = match shape.as_slice() {
        [_] => 1,
        [_, c] if *c >= 1 => *c,
        _ => {
            return Err(PyValueError::new_err(format!(
                "audio must be 1-D (mono) or 2-D (frames, channels), got shape {shape:?}"
            )))
        }
    };
    let raw = np
        .call_method1("ascontiguousarray", (a,))?
        .call_method0("tobytes")?;
    let flat: Vec<f64> = raw
        .cast::<PyBytes>()?
        .as_bytes()
        .chunks_exact(8)
        .map(|b| f64::from_ne_bytes(b.try_into().expect("8-byte chunks")))
        .collect();
    if !(sample_rate.is_finite() && sample_rate > 0.0) {
        return Err(PyValueError::new_err(format!(
            "sample_rate must be positive, got {sample_rate}"
        )));
    }
    let mono: Vec<f64> = flat
        .chunks_exact(channels)
        .map(|c| c.iter().sum::<f64>() / channels as f64)
        .collect();
    if mono.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err("audio: non-finite samples"));
    }
    let f = py
        .detach(|| tactus::analysis::features::sound_features(&mono, sample_rate))
        .map_err(|e| PyValueError::new_err(format!("no features: {e}")))?;
    let d = PyDict::new(py);
    for (name, v) in tactus::analysis::features::FEATURE_NAMES.iter().zip(f.values()) {
        d.set_item(name, v)?;
    }
    Ok(d)
}

/// Tactus: physically based contact sounds (impacts, scraping, rolling) from a modal resonator
/// bank. `render` a scene to a NumPy array, `batch` variations into a folder of WAV files,
/// `fit` a material preset from recordings, `features` of any signal as `tactus eval`
/// measures them, `materials` to list the built-in materials, `surfaces` the scraping and rolling surfaces. See docs/python.md.
#[pymodule]
#[pyo3(name = "tactus")]
fn tactus_py(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(batch, m)?)?;
    m.add_function(wrap_pyfunction!(fit, m)?)?;
    m.add_function(wrap_pyfunction!(materials, m)?)?;
    m.add_function(wrap_pyfunction!(surfaces, m)?)?;
    m.add_function(wrap_pyfunction!(features, m)?)?;
    m.add("DEMO_SCENE", scene::DEMO_SCENE)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
