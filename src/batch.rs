//! `tactus batch`: many renders of one scene with varied parameters (or of a JSON-lines file of
//! scenes) into a folder of WAVs plus a manifest of what each file was rendered with. The format
//! of the variation spec, sharding and resuming are documented in `docs/batch.md`.
//!
//! Every item is a pure function of its index: its scene (the base scene with the spec's values
//! for that index), its file name and its manifest row. So items render in any order, on any
//! number of threads or machines (`--shard I/N` takes the indices `i` with `i % N == I`), and
//! the result is byte-identical. Files are written under a temporary name and renamed when
//! complete; a rerun skips every file already there. Manifest rows are written in index order
//! as each chunk of items finishes (memory does not grow with the batch) and the manifest is
//! renamed into place only when the run completes; rows are rebuilt from the files on a rerun.

use crate::scene::Scene;
use crate::wav::{self, WavFormat, WavHeader};
use crate::work::Observer;
use anyhow::Context;
use serde::Deserialize;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A deterministic slice of a batch: the items `i` with `i % count == index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, 0-based.
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// The whole batch.
    pub const ALL: Shard = Shard { index: 0, count: 1 };
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("shard must be I/N with 0 <= I < N (e.g. 0/4), got '{s}'");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// How files are written.
#[derive(Debug, Clone, Copy)]
pub struct Output {
    /// Sample format.
    pub format: WavFormat,
    /// Header layout.
    pub header: WavHeader,
    /// Processing block size.
    pub block: usize,
    /// Pass each render through the output limiter ([`crate::engine::limiter`]) before it is
    /// written; off, the float render is written unlimited.
    pub limit: bool,
}

/// One varied parameter of a spec.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Param {
    /// JSON pointer into the scene (RFC 6901), e.g. `/settings/damping`.
    path: String,
    uniform: Option<[f64; 2]>,
    log_uniform: Option<[f64; 2]>,
    grid: Option<Vec<Value>>,
    int_range: Option<[u64; 2]>,
}

/// What a parameter does at an item.
#[derive(Debug, Clone)]
enum Kind {
    Uniform(f64, f64),
    LogUniform(f64, f64),
    Grid(Vec<Value>),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    scene: Value,
    #[serde(default = "one")]
    samples: usize,
    #[serde(default = "one_u64")]
    seed: u64,
    #[serde(default)]
    params: Vec<Param>,
}

fn one() -> usize {
    1
}
fn one_u64() -> u64 {
    1
}

/// Where a batch's scenes come from.
enum Source {
    /// A base scene and its variations.
    Spec {
        base: Value,
        params: Vec<(String, Kind)>,
        samples: usize,
        seed: u64,
    },
    /// One scene per non-empty line.
    Lines { path: PathBuf },
}

/// A parsed batch: its items and how to build each one's scene.
pub struct Batch {
    source: Source,
    /// Preset paths in scenes resolve against this folder.
    base_dir: Option<PathBuf>,
    /// Number of items.
    pub items: usize,
    /// What identifies this batch's files (spec or scenes, and output settings), stored in the
    /// output folder so a rerun into it with a different batch is refused.
    fingerprint: String,
}

impl Batch {
    /// Reads a variation spec (docs/batch.md).
    pub fn from_spec(path: &Path, out: Output) -> anyhow::Result<Batch> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read spec {}", path.display()))?;
        Batch::from_spec_text(&text, &path.display().to_string(), path.parent(), out)
    }

    /// A variation spec given as text (the Python module's specs are dicts or strings): `name`
    /// stands for the spec in errors, `dir` resolves the spec's relative scene and preset paths
    /// (the working directory when `None`).
    pub fn from_spec_text(text: &str, name: &str, dir: Option<&Path>, out: Output) -> anyhow::Result<Batch> {
        let spec: SpecFile = serde_json::from_str(text).map_err(|e| anyhow::anyhow!("spec {name}: {e}"))?;
        let dir = dir.map(Path::to_path_buf);
        let (base, base_dir) = match spec.scene {
            Value::String(file) => {
                let p = dir.clone().unwrap_or_default().join(&file);
                let t = std::fs::read_to_string(&p)
                    .with_context(|| format!("spec {name}: cannot read scene {}", p.display()))?;
                let v: Value = serde_json::from_str(&t)
                    .map_err(|e| anyhow::anyhow!("scene {}: invalid scene JSON: {e}", p.display()))?;
                (v, p.parent().map(Path::to_path_buf))
            }
            v @ Value::Object(_) => (v, dir),
            other => anyhow::bail!(
                "spec {name}: `scene` must be a scene file name or an inline scene object, got {other}"
            ),
        };
        if spec.samples == 0 {
            anyhow::bail!("spec {name}: `samples` must be at least 1");
        }
        let mut params = Vec::new();
        let mut grid_len: usize = 1;
        for (k, p) in spec.params.iter().enumerate() {
            let at = format!("spec {name}: params[{k}] ({})", p.path);
            if !p.path.starts_with('/') {
                anyhow::bail!(
                    "{at}: `path` must be a JSON pointer starting with '/', e.g. /settings/damping"
                );
            }
            let kind = match (&p.uniform, &p.log_uniform, &p.grid, &p.int_range) {
                (Some([lo, hi]), None, None, None) => {
                    if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                        anyhow::bail!("{at}: uniform needs finite [lo, hi] with lo <= hi, got [{lo}, {hi}]");
                    }
                    Kind::Uniform(*lo, *hi)
                }
                (None, Some([lo, hi]), None, None) => {
                    if !(lo.is_finite() && hi.is_finite() && *lo > 0.0 && lo <= hi) {
                        anyhow::bail!("{at}: log_uniform needs 0 < lo <= hi, got [{lo}, {hi}]");
                    }
                    Kind::LogUniform(*lo, *hi)
                }
                (None, None, Some(values), None) => {
                    if values.is_empty() {
                        anyhow::bail!("{at}: grid needs at least one value");
                    }
                    Kind::Grid(values.clone())
                }
                (None, None, None, Some([from, to])) => {
                    if from > to || to - from >= 10_000_000 {
                        anyhow::bail!("{at}: int_range needs [from, to] with from <= to and at most 10^7 values, got [{from}, {to}]");
                    }
                    Kind::Grid((*from..=*to).map(Value::from).collect())
                }
                _ => anyhow::bail!("{at}: give exactly one of uniform, log_uniform, grid, int_range"),
            };
            if let Kind::Grid(v) = &kind {
                grid_len = grid_len
                    .checked_mul(v.len())
                    .filter(|n| *n <= 100_000_000)
                    .ok_or_else(|| anyhow::anyhow!("{at}: the grid has more than 10^8 points"))?;
            }
            params.push((p.path.clone(), kind));
        }
        let items = grid_len
            .checked_mul(spec.samples)
            .filter(|n| *n <= 100_000_000)
            .ok_or_else(|| anyhow::anyhow!("spec {name}: more than 10^8 items"))?;
        let source = Source::Spec {
            base,
            params,
            samples: spec.samples,
            seed: spec.seed,
        };
        // The spec as read (scene inlined) identifies the batch.
        let mut canon: Value = serde_json::from_str(text)?;
        if let Source::Spec { base, .. } = &source {
            canon["scene"] = base.clone();
        }
        let fingerprint = fingerprint(&canon.to_string(), items, out);
        let batch = Batch {
            source,
            base_dir,
            items,
            fingerprint,
        };
        // Fail on a spec whose values the scene rejects before rendering anything: the first
        // item and, for sampled parameters, both ends of each range.
        batch.check_ranges().with_context(|| format!("spec {name}"))?;
        Ok(batch)
    }

    /// Reads a JSON-lines file of scenes (each line a scene, or a manifest row with a `scene`).
    pub fn from_lines(path: &Path, out: Output) -> anyhow::Result<Batch> {
        let f = std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
        let mut items = 0;
        let mut hash = Fnv::new();
        for line in BufReader::new(f).lines() {
            let line = line.with_context(|| format!("cannot read {}", path.display()))?;
            if !line.trim().is_empty() {
                items += 1;
                hash.add(line.trim().as_bytes());
                hash.add(b"\n");
            }
        }
        if items == 0 {
            anyhow::bail!("{}: no scenes (one JSON scene per line expected)", path.display());
        }
        Ok(Batch {
            source: Source::Lines { path: path.into() },
            base_dir: path.parent().map(Path::to_path_buf),
            items,
            fingerprint: fingerprint(&format!("lines {:016x}", hash.0), items, out),
        })
    }

    /// Scene of item `i` (Spec source) with the parameters' values, in spec order.
    fn spec_item(&self, i: usize) -> anyhow::Result<(Value, Vec<Value>)> {
        let Source::Spec {
            base,
            params,
            samples,
            seed,
        } = &self.source
        else {
            unreachable!("spec_item on a spec batch only")
        };
        let mut scene = base.clone();
        let mut values = Vec::with_capacity(params.len());
        // Grid point: mixed radix over the grid parameters, the last one fastest.
        let mut g = i / samples;
        let mut grid_values = vec![Value::Null; params.len()];
        for (k, (_, kind)) in params.iter().enumerate().rev() {
            if let Kind::Grid(v) = kind {
                grid_values[k] = v[g % v.len()].clone();
                g /= v.len();
            }
        }
        for (k, (path, kind)) in params.iter().enumerate() {
            let u = unit(*seed, i as u64, k as u64);
            let v = match kind {
                Kind::Uniform(lo, hi) => json!(lo + u * (hi - lo)),
                Kind::LogUniform(lo, hi) => json!((lo.ln() + u * (hi.ln() - lo.ln())).exp().clamp(*lo, *hi)),
                Kind::Grid(_) => std::mem::take(&mut grid_values[k]),
            };
            set_pointer(&mut scene, path, v.clone()).with_context(|| format!("params[{k}] ({path})"))?;
            values.push(v);
        }
        Ok((scene, values))
    }

    fn check_ranges(&self) -> anyhow::Result<()> {
        let Source::Spec { params, .. } = &self.source else {
            return Ok(());
        };
        let (scene, _) = self.spec_item(0)?;
        Scene::from_value(scene.clone(), self.base_dir.as_deref()).context("item 0")?;
        for (k, (path, kind)) in params.iter().enumerate() {
            let ends = match kind {
                Kind::Uniform(lo, hi) | Kind::LogUniform(lo, hi) => [*lo, *hi],
                Kind::Grid(_) => continue,
            };
            for v in ends {
                let mut s = scene.clone();
                set_pointer(&mut s, path, json!(v))?;
                Scene::from_value(s, self.base_dir.as_deref())
                    .with_context(|| format!("params[{k}] ({path}) at {v}"))?;
            }
        }
        Ok(())
    }

    /// Column names of the varied parameters.
    fn param_names(&self) -> Vec<String> {
        match &self.source {
            Source::Spec { params, .. } => params.iter().map(|(p, _)| p.clone()).collect(),
            Source::Lines { .. } => Vec::new(),
        }
    }

    fn file_name(&self, i: usize) -> String {
        let width = (self.items.saturating_sub(1)).to_string().len().max(6);
        format!("{i:0width$}.wav")
    }
}

/// A stable 64-bit FNV-1a hash (the fingerprint must not change between builds, unlike std's).
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn add(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= u64::from(*b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

fn fingerprint(what: &str, items: usize, out: Output) -> String {
    let mut h = Fnv::new();
    h.add(what.as_bytes());
    let mut v = json!({
        "items": items,
        "source_fnv1a64": format!("{:016x}", h.0),
        "format": format!("{:?}", out.format).to_lowercase(),
        "wav_header": format!("{:?}", out.header).to_lowercase(),
        "block": out.block,
    });
    // Only when on, so folders rendered before the option keep their fingerprint.
    if out.limit {
        v["limit"] = json!(true);
    }
    v.to_string()
}

/// A uniform number in [0, 1) from (seed, item, parameter): SplitMix64 over the three, so each
/// item's values depend on nothing but its index (any order, any shard).
fn unit(seed: u64, item: u64, param: u64) -> f64 {
    let mut x = seed;
    for v in [item, param] {
        x = splitmix(x ^ splitmix(v.wrapping_add(0x9e37_79b9_7f4a_7c15)));
    }
    (x >> 11) as f64 / (1u64 << 53) as f64
}

fn splitmix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Sets the value at JSON pointer `ptr`, creating missing object members on the way (so
/// `/settings/damping` works on a scene without `settings`); array elements must exist.
fn set_pointer(root: &mut Value, ptr: &str, v: Value) -> anyhow::Result<()> {
    let tokens: Vec<String> = ptr
        .split('/')
        .skip(1)
        .map(|t| t.replace("~1", "/").replace("~0", "~"))
        .collect();
    let mut cur = root;
    for (n, t) in tokens.iter().enumerate() {
        let last = n + 1 == tokens.len();
        cur = match cur {
            Value::Object(m) => {
                if last {
                    m.insert(t.clone(), v);
                    return Ok(());
                }
                m.entry(t.clone()).or_insert_with(|| json!({}))
            }
            Value::Array(a) => {
                let len = a.len();
                let idx: usize = t
                    .parse()
                    .ok()
                    .filter(|i| *i < len)
                    .ok_or_else(|| anyhow::anyhow!("'{t}' is not an index of an array of {len}"))?;
                if last {
                    a[idx] = v;
                    return Ok(());
                }
                &mut a[idx]
            }
            other => anyhow::bail!("cannot go into '{t}': the scene has {other} there"),
        };
    }
    anyhow::bail!("path must name a field below the scene's root")
}

/// One finished item.
struct Row {
    index: usize,
    file: String,
    seed: u64,
    values: Vec<Value>,
    scene: Value,
    duration_s: f64,
    peak: f64,
    rms: f64,
}

/// What a run did.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Summary {
    /// Items rendered by this run.
    pub rendered: usize,
    /// Items whose file was already there.
    pub skipped: usize,
}

/// Largest processing block, samples (`--block`; the engine's largest prepared block).
pub const MAX_BLOCK: usize = 8192;

/// Checks a processing block size: `Err` says the allowed range and the value (the caller names
/// the option).
pub fn check_block(block: usize) -> Result<(), String> {
    if (1..=MAX_BLOCK).contains(&block) {
        Ok(())
    } else {
        Err(format!("must be in 1..={MAX_BLOCK}, got {block}"))
    }
}

/// The manifest names of a run: `manifest` or `manifest-shard-I-of-N`.
pub fn manifest_stem(shard: Shard) -> String {
    if shard.count == 1 {
        "manifest".into()
    } else {
        format!("manifest-shard-{}-of-{}", shard.index, shard.count)
    }
}

/// Renders this shard of `batch` into `dir` (created if missing) with `threads` threads
/// (rayon's default: one per core). `observer` hears the item count and each item done; once it
/// is cancelled the batch stops with an error ("batch interrupted"): items not yet started are
/// not rendered, the finished files stay (a rerun resumes) and no manifest is written.
pub fn run(
    batch: &Batch,
    dir: &Path,
    out: Output,
    shard: Shard,
    threads: Option<usize>,
    observer: &dyn Observer,
) -> anyhow::Result<Summary> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    check_fingerprint(dir, &batch.fingerprint)?;
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        if t == 0 {
            anyhow::bail!("--threads must be at least 1");
        }
        pool = pool.num_threads(t);
    }
    let pool = pool.build().context("cannot start worker threads")?;
    let count = (batch.items + shard.count - 1 - shard.index) / shard.count;
    observer.started(count as u64);
    let stem = manifest_stem(shard);
    let (jsonl_path, csv_path) = (dir.join(format!("{stem}.jsonl")), dir.join(format!("{stem}.csv")));
    let (jsonl_tmp, csv_tmp) = (
        dir.join(format!(".{stem}.jsonl.partial")),
        dir.join(format!(".{stem}.csv.partial")),
    );
    let create = |p: &Path| -> anyhow::Result<BufWriter<std::fs::File>> {
        Ok(BufWriter::new(
            std::fs::File::create(p).with_context(|| format!("cannot write {}", p.display()))?,
        ))
    };
    let (mut jsonl, mut csv) = (create(&jsonl_tmp)?, create(&csv_tmp)?);
    let names = batch.param_names();
    let mut header = vec!["file".to_string(), "index".into(), "seed".into()];
    header.extend(names.iter().cloned());
    header.extend(["duration_s".into(), "peak".into(), "rms".into()]);
    writeln!(
        csv,
        "{}",
        header.iter().map(|h| csv_field(h)).collect::<Vec<_>>().join(",")
    )?;

    let rendered = AtomicUsize::new(0);
    let skipped = AtomicUsize::new(0);
    let chunk = 32 * pool.current_num_threads();
    let mut lines = match &batch.source {
        Source::Lines { path } => Some(
            BufReader::new(
                std::fs::File::open(path).with_context(|| format!("cannot read {}", path.display()))?,
            )
            .lines()
            .filter(|l| l.as_ref().map_or(true, |l| !l.trim().is_empty()))
            .enumerate(),
        ),
        Source::Spec { .. } => None,
    };
    let mut next = shard.index;
    while next < batch.items {
        // This chunk's items (with their scene lines for a lines source).
        let mut work: Vec<(usize, Option<String>)> = Vec::with_capacity(chunk);
        while work.len() < chunk && next < batch.items {
            let line = match &mut lines {
                Some(it) => loop {
                    let Some((k, l)) = it.next() else {
                        anyhow::bail!("the scenes file changed while the batch ran");
                    };
                    if k == next {
                        break Some(l?);
                    }
                },
                None => None,
            };
            work.push((next, line));
            next += shard.count;
        }
        let rows: Vec<anyhow::Result<Row>> = pool.install(|| {
            use rayon::prelude::*;
            work.into_par_iter()
                .map(|(i, line)| {
                    if observer.cancelled() {
                        anyhow::bail!("batch interrupted");
                    }
                    let r = item(batch, dir, out, i, line, &rendered, &skipped)
                        .with_context(|| format!("item {i} ({})", batch.file_name(i)));
                    observer.advanced("item", 1);
                    r
                })
                .collect()
        });
        for row in rows {
            let row = row?;
            write_row(&mut jsonl, &mut csv, &row, &names)?;
        }
        jsonl.flush()?;
        csv.flush()?;
    }
    drop((jsonl, csv));
    std::fs::rename(&jsonl_tmp, &jsonl_path)
        .with_context(|| format!("cannot write {}", jsonl_path.display()))?;
    std::fs::rename(&csv_tmp, &csv_path).with_context(|| format!("cannot write {}", csv_path.display()))?;
    Ok(Summary {
        rendered: rendered.into_inner(),
        skipped: skipped.into_inner(),
    })
}

/// Refuses a folder that holds another batch's files; records this batch's identity otherwise.
fn check_fingerprint(dir: &Path, fp: &str) -> anyhow::Result<()> {
    let path = dir.join("batch.json");
    match std::fs::read_to_string(&path) {
        Ok(old) if old.trim() == fp => Ok(()),
        Ok(old) => anyhow::bail!(
            "{} holds files of another batch ({} says {}, this batch is {fp}); use a new folder",
            dir.display(),
            path.display(),
            old.trim()
        ),
        Err(_) => {
            // Shards may start together on a shared folder: write whole, then rename.
            let tmp = dir.join(format!(".batch.json.{}.partial", std::process::id()));
            std::fs::write(&tmp, format!("{fp}\n"))
                .with_context(|| format!("cannot write {}", tmp.display()))?;
            std::fs::rename(&tmp, &path).with_context(|| format!("cannot write {}", path.display()))?;
            Ok(())
        }
    }
}

fn item(
    batch: &Batch,
    dir: &Path,
    out: Output,
    i: usize,
    line: Option<String>,
    rendered: &AtomicUsize,
    skipped: &AtomicUsize,
) -> anyhow::Result<Row> {
    let (scene, values) = match line {
        Some(l) => {
            let v: Value = serde_json::from_str(&l).map_err(|e| anyhow::anyhow!("invalid JSON: {e}"))?;
            // A manifest row carries its scene; anything else is the scene itself.
            let scene = match v {
                Value::Object(mut m) if m.contains_key("scene") && m.contains_key("file") => {
                    m.remove("scene").expect("checked")
                }
                other => other,
            };
            (scene, Vec::new())
        }
        None => batch.spec_item(i)?,
    };
    let loaded = Scene::from_value(scene.clone(), batch.base_dir.as_deref())?;
    let file = batch.file_name(i);
    let path = dir.join(&file);
    if path.exists() {
        skipped.fetch_add(1, Ordering::Relaxed);
    } else {
        let (mut l, mut r) = crate::scene::render(&loaded, out.block);
        if out.limit {
            crate::engine::limiter::Limiter::new(loaded.scene.sample_rate as f64)
                .process_stereo(&mut l, &mut r);
        }
        let tmp = dir.join(format!(".{file}.partial"));
        wav::write_stereo(&tmp, loaded.scene.sample_rate, &l, &r, out.format, out.header)?;
        std::fs::rename(&tmp, &path).with_context(|| format!("cannot write {}", path.display()))?;
        rendered.fetch_add(1, Ordering::Relaxed);
    }
    let (duration_s, peak, rms) = wav::file_peak_rms(&path)?;
    Ok(Row {
        index: i,
        file,
        seed: loaded.scene.seed,
        values,
        scene,
        duration_s,
        peak,
        rms,
    })
}

fn write_row(
    jsonl: &mut impl Write,
    csv: &mut impl Write,
    row: &Row,
    names: &[String],
) -> anyhow::Result<()> {
    let params: serde_json::Map<String, Value> =
        names.iter().cloned().zip(row.values.iter().cloned()).collect();
    let j = json!({
        "file": row.file,
        "index": row.index,
        "seed": row.seed,
        "params": params,
        "duration_s": row.duration_s,
        "peak": row.peak,
        "rms": row.rms,
        "scene": row.scene,
    });
    writeln!(jsonl, "{j}")?;
    let mut fields = vec![csv_field(&row.file), row.index.to_string(), row.seed.to_string()];
    fields.extend(row.values.iter().map(|v| match v {
        Value::String(s) => csv_field(s),
        other => csv_field(&other.to_string()),
    }));
    fields.extend([row.duration_s, row.peak, row.rms].map(|v| json!(v).to_string()));
    writeln!(csv, "{}", fields.join(","))?;
    Ok(())
}

/// RFC 4180 quoting where needed.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Merges the shard manifests in `dir` (`manifest-shard-I-of-N.{jsonl,csv}`, all N present)
/// into `manifest.jsonl` and `manifest.csv`, byte-identical to an unsharded run's. Streams:
/// shard I holds items I, I+N, …, so taking one row of each shard in turn restores index order.
pub fn merge_manifests(dir: &Path) -> anyhow::Result<usize> {
    let mut count = None;
    for e in std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))? {
        let name = e?.file_name().to_string_lossy().into_owned();
        if let Some(rest) = name
            .strip_prefix("manifest-shard-")
            .and_then(|r| r.strip_suffix(".jsonl"))
        {
            let n: usize = rest
                .split_once("-of-")
                .and_then(|(_, n)| n.parse().ok())
                .ok_or_else(|| anyhow::anyhow!("{}: unexpected manifest name {name}", dir.display()))?;
            if count.is_some_and(|c| c != n) {
                anyhow::bail!(
                    "{}: manifests of different shard counts ({} and {n})",
                    dir.display(),
                    count.unwrap_or(0)
                );
            }
            count = Some(n);
        }
    }
    let n =
        count.ok_or_else(|| anyhow::anyhow!("{}: no manifest-shard-I-of-N.jsonl files", dir.display()))?;
    let mut rows = 0;
    for ext in ["jsonl", "csv"] {
        let mut readers = Vec::with_capacity(n);
        for i in 0..n {
            let p = dir.join(format!("manifest-shard-{i}-of-{n}.{ext}"));
            let f = std::fs::File::open(&p).with_context(|| {
                format!("shard {i}/{n} has no finished manifest ({} missing)", p.display())
            })?;
            readers.push(BufReader::new(f).lines());
        }
        let tmp = dir.join(format!(".manifest.{ext}.partial"));
        let mut w = BufWriter::new(
            std::fs::File::create(&tmp).with_context(|| format!("cannot write {}", tmp.display()))?,
        );
        if ext == "csv" {
            let mut header = None;
            for (i, r) in readers.iter_mut().enumerate() {
                let h = r.next().transpose()?.unwrap_or_default();
                if header.as_ref().is_some_and(|x| *x != h) {
                    anyhow::bail!("shard {i}/{n}: csv header differs from shard 0's");
                }
                header = Some(h);
            }
            writeln!(w, "{}", header.unwrap_or_default())?;
        }
        let mut written = 0;
        'rounds: loop {
            for i in 0..n {
                if let Some(line) = readers[i].next().transpose()? {
                    writeln!(w, "{line}")?;
                    written += 1;
                    continue;
                }
                // Shard i ran out at item index i + kN: the others hold nothing past it.
                for (j, r) in readers.iter_mut().enumerate().filter(|(j, _)| *j != i) {
                    if r.next().transpose()?.is_some() {
                        anyhow::bail!(
                            "shard {j}/{n}'s manifest has rows past shard {i}/{n}'s last: the manifests are not of one batch"
                        );
                    }
                }
                break 'rounds;
            }
        }
        rows = written;
        w.flush()?;
        drop(w);
        std::fs::rename(&tmp, dir.join(format!("manifest.{ext}")))?;
    }
    Ok(rows)
}
