//! Measured mode tables as a fit input (docs/measured.md): the frequencies, onset levels and
//! ring times of objects' modes, measured (Traer et al. 2019's tables of everyday objects) or
//! computed (a FEM or other modal tool), pooled into a preset as fitted recordings are: each
//! object of a table becomes one [`FileResult`] whose modes are the table's, and
//! [`crate::fit::pool::preset::assemble`] pools them (distribution, damping law, spacing).
//!
//! Two formats:
//! - **JSON** as PyImpact ships its tables: `{"cf": [Hz…], "op": [dB…], "rt": [s…]}`, one row
//!   per mode. PyImpact draws an object from the first [`OBJECT_ROWS`] rows; a longer table
//!   (its size classes 0–1 hold up to 475 rows, repeated strikes of many objects) is read as
//!   consecutive objects of that many rows, a shorter last run left out.
//! - **CSV** (`.csv`, `.txt`): one mode per line, `object,frequency_hz,level_db,t60_s`; a
//!   header line, blank lines and `#` comments are skipped; the rows of one `object` name are
//!   one object.
//!
//! A file named `<anything>_<class>_mm.<ext>` (PyImpact's naming) carries the size class
//! `<class>` (0–5); tables with size classes pool into a sized preset whose families are drawn
//! at their classes' sizes ([`size_class_of`], [`SIZE_CLASSES`]).

use crate::analysis::signal::Mode;
use crate::fit::pool::preset::{assemble, Groups};
use crate::fit::pool::Pooling;
use crate::fit::recording::{bands, FileResult};
use crate::preset::{
    ModeModel, Origin, Preset, SizeClass, DECAY_RANGE_DB_PER_S, FREQ_RANGE_HZ, LEVEL_RANGE_DB,
};
use std::path::{Path, PathBuf};

/// Rows of a JSON table that make one object: the modes PyImpact draws an object from.
pub const OBJECT_ROWS: usize = 10;

/// Summed bounding-box extents (x + y + z, m) of the object `size = 1` stands for: the
/// geometric centre of PyImpact's size class 2 (0.1–0.5 m), a hand-sized object (a mug, a
/// jar, a box).
pub const REFERENCE_EXTENT_M: f64 = 0.223_606_797_749_979;

/// Size `s` stands for summed extents [`REFERENCE_EXTENT_M`]` · s^EXTENT_EXPONENT`. Why 2: the
/// plugin's Size knob spans ×0.25–×4 ([`KNOB_SIZE_RANGE`]), the tables' classes 0.05–10 m;
/// with the square, the knob reaches every class (×0.25 is 1.4 cm, ×4 is 3.6 m).
pub const EXTENT_EXPONENT: f64 = 2.0;

/// The plugin's Size knob range (`params::size_range`): every class sounds its own table at a
/// size inside it.
pub const KNOB_SIZE_RANGE: (f64, f64) = (0.25, 4.0);

/// The largest size the engine takes (`ImpactSettings::size`): the top class reaches it.
const MAX_SIZE: f64 = 100.0;

/// PyImpact's size classes by summed extents, m: (class, lowest exclusive, highest
/// inclusive). Class 1 is left out: PyImpact tests `≤ 0.02` after `≤ 0.1`, so it never picks
/// it, and no extent is known for it.
pub const SIZE_CLASSES: [(u8, f64, f64); 5] = [
    (0, 0.0, 0.1),
    (2, 0.1, 0.5),
    (3, 0.5, 1.0),
    (4, 1.0, 3.0),
    (5, 3.0, 10.0),
];

/// The size standing for summed extents `extent_m` ([`EXTENT_EXPONENT`]).
pub fn size_of_extent(extent_m: f64) -> f64 {
    (extent_m / REFERENCE_EXTENT_M).powf(1.0 / EXTENT_EXPONENT)
}

/// The sizes of PyImpact size class `class` ([`SIZE_CLASSES`], the top class reaching the
/// largest size), and the size at which it sounds its table's own frequencies: the geometric
/// centre of its sizes within the knob's range ([`KNOB_SIZE_RANGE`]; size 1 for class 2).
/// `None` for class 1 and unknown classes.
pub fn size_class(class: u8) -> Option<SizeClass> {
    let last = SIZE_CLASSES[SIZE_CLASSES.len() - 1].0;
    SIZE_CLASSES.iter().find(|c| c.0 == class).map(|&(c, lo, hi)| {
        let low = size_of_extent(lo);
        let high = if c == last { MAX_SIZE } else { size_of_extent(hi) };
        let (a, b) = (low.max(KNOB_SIZE_RANGE.0), high.min(KNOB_SIZE_RANGE.1));
        SizeClass {
            low,
            high,
            reference: (a * b).sqrt(),
        }
    })
}

/// One object of a table: its modes (levels dB, decays dB/s, no phase, build-up or ring).
#[derive(Debug, Clone, PartialEq)]
pub struct TableObject {
    /// The object's name: its `object` column, or `rows a–b` of a JSON table.
    pub name: String,
    /// Its modes, in table order.
    pub modes: Vec<Mode>,
}

/// A mode table read from a file.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeTable {
    /// The file.
    pub path: PathBuf,
    /// PyImpact size class from the file name (`…_<class>_mm.<ext>`), if it has one.
    pub size_class: Option<u8>,
    /// The objects, in file order.
    pub objects: Vec<TableObject>,
    /// Notes on rows read but not used (a short last run of a long JSON table).
    pub notes: Vec<String>,
}

impl ModeTable {
    /// The table with only its first `n` objects (PyImpact draws from the first one).
    pub fn first_objects(mut self, n: usize) -> Self {
        if self.objects.len() > n {
            self.notes.push(format!(
                "{}: the first {n} of its {} objects kept",
                short(&self.path),
                self.objects.len()
            ));
            self.objects.truncate(n);
        }
        self
    }
}

/// Whether `path` is a mode table rather than a recording or a preset: a `.csv` or `.txt`
/// file, or a `.json` file whose top level has a `cf` array. A `.json` file that is not valid
/// JSON counts as a table, so that reading it says what is wrong with it.
pub fn is_table_path(path: &Path) -> bool {
    match extension(path).as_str() {
        "csv" | "txt" => true,
        "json" => std::fs::read_to_string(path).ok().is_some_and(|t| {
            serde_json::from_str::<serde_json::Value>(&t).map_or(true, |v| v.get("cf").is_some())
        }),
        _ => false,
    }
}

fn extension(path: &Path) -> String {
    path.extension()
        .map(|x| x.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// The size class in a PyImpact table's file name, `<anything>_<class>_mm.<ext>`.
pub fn size_class_of(path: &Path) -> Option<u8> {
    let stem = path.file_stem()?.to_string_lossy().to_ascii_lowercase();
    let rest = stem.strip_suffix("_mm")?;
    let digit = rest.rsplit('_').next()?;
    (digit.len() == 1).then(|| digit.parse().ok()).flatten()
}

/// Reads the mode table at `path` (JSON or CSV by its extension). Errors are one line naming
/// the file and, for CSV, the line: a malformed table, a non-finite number, a frequency
/// outside 10 Hz–100 kHz, a ring time that is not a positive number.
pub fn read(path: &Path) -> anyhow::Result<ModeTable> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("{}: cannot read the mode table ({e})", path.display()))?;
    let (objects, notes) = match extension(path).as_str() {
        "json" => parse_json(&text),
        "csv" | "txt" => parse_csv(&text).map(|o| (o, Vec::new())),
        other => Err(format!(
            "not a mode table (extension '{other}'; tables are .json or .csv/.txt)"
        )),
    }
    .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    if objects.is_empty() {
        anyhow::bail!("{}: the mode table holds no object", path.display());
    }
    Ok(ModeTable {
        path: path.to_path_buf(),
        size_class: size_class_of(path),
        objects,
        notes: notes
            .into_iter()
            .map(|n| format!("{}: {n}", short(path)))
            .collect(),
    })
}

/// One mode from a table row, checked; `at` says where, for errors.
fn mode(freq_hz: f64, level_db: f64, t60_s: f64, at: &str) -> Result<Mode, String> {
    if !(freq_hz.is_finite() && (FREQ_RANGE_HZ.0..=FREQ_RANGE_HZ.1).contains(&freq_hz)) {
        return Err(format!(
            "{at}: frequency {freq_hz} Hz is not a finite number in {}–{} Hz",
            FREQ_RANGE_HZ.0, FREQ_RANGE_HZ.1
        ));
    }
    if !(level_db.is_finite() && (LEVEL_RANGE_DB.0..=LEVEL_RANGE_DB.1).contains(&level_db)) {
        return Err(format!(
            "{at}: level {level_db} dB is not a finite number in {} to {} dB",
            LEVEL_RANGE_DB.0, LEVEL_RANGE_DB.1
        ));
    }
    if !(t60_s.is_finite() && t60_s > 0.0) {
        return Err(format!(
            "{at}: ring time (T60) {t60_s} s is not a finite positive number"
        ));
    }
    let decay = 60.0 / t60_s;
    if decay > DECAY_RANGE_DB_PER_S.1 {
        return Err(format!(
            "{at}: ring time (T60) {t60_s} s is shorter than {} ms",
            60e3 / DECAY_RANGE_DB_PER_S.1
        ));
    }
    Ok(Mode {
        freq_hz,
        level_db,
        decay_db_per_s: decay,
        phase: 0.0,
        attack_s: 0.0,
        ring: None,
    })
}

fn parse_json(text: &str) -> Result<(Vec<TableObject>, Vec<String>), String> {
    let v: serde_json::Value =
        serde_json::from_str(text).map_err(|e| format!("not a mode table: not valid JSON ({e})"))?;
    let column = |key: &str, what: &str| -> Result<Vec<f64>, String> {
        let arr = v
            .get(key)
            .and_then(|c| c.as_array())
            .ok_or_else(|| format!("not a mode table: no \"{key}\" array ({what}); a JSON table is {{\"cf\": [Hz…], \"op\": [dB…], \"rt\": [s…]}}"))?;
        arr.iter()
            .enumerate()
            .map(|(i, x)| {
                x.as_f64()
                    .ok_or_else(|| format!("\"{key}\"[{i}] is not a number: {x}"))
            })
            .collect()
    };
    let cf = column("cf", "mode frequencies, Hz")?;
    let op = column("op", "onset levels, dB")?;
    let rt = column("rt", "ring times (T60), s")?;
    if cf.len() != op.len() || cf.len() != rt.len() {
        return Err(format!(
            "malformed mode table: \"cf\", \"op\" and \"rt\" differ in length ({}, {}, {})",
            cf.len(),
            op.len(),
            rt.len()
        ));
    }
    let modes = (0..cf.len())
        .map(|i| mode(cf[i], op[i], rt[i], &format!("row {i}")))
        .collect::<Result<Vec<Mode>, String>>()?;
    let mut notes = Vec::new();
    let mut objects = Vec::new();
    for (k, run) in modes.chunks(OBJECT_ROWS).enumerate() {
        let (a, b) = (k * OBJECT_ROWS, k * OBJECT_ROWS + run.len() - 1);
        if run.len() < OBJECT_ROWS && k > 0 {
            notes.push(format!(
                "rows {a}–{b} left out: {} rows, short of an object's {OBJECT_ROWS}",
                run.len()
            ));
            continue;
        }
        if run.len() < 2 {
            return Err(format!(
                "malformed mode table: {} row(s), an object needs at least 2 modes",
                run.len()
            ));
        }
        objects.push(TableObject {
            name: format!("rows {a}–{b}"),
            modes: run.to_vec(),
        });
    }
    Ok((objects, notes))
}

fn parse_csv(text: &str) -> Result<Vec<TableObject>, String> {
    let mut objects: Vec<TableObject> = Vec::new();
    let mut seen_data = false;
    for (n, line) in text.lines().enumerate() {
        let at = format!("line {}", n + 1);
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        if cols.len() != 4 {
            return Err(format!(
                "{at}: malformed mode table: {} columns, expected 4 (object,frequency_hz,level_db,t60_s)",
                cols.len()
            ));
        }
        let nums: Vec<Result<f64, _>> = cols[1..].iter().map(|c| c.parse::<f64>()).collect();
        if !seen_data && nums.iter().all(Result::is_err) {
            // The header.
            continue;
        }
        seen_data = true;
        let mut vals = [0.0; 3];
        for (i, (v, c)) in nums.into_iter().zip(&cols[1..]).enumerate() {
            vals[i] = v.map_err(|_| {
                format!(
                    "{at}: malformed mode table: column {} ('{c}') is not a number",
                    i + 2
                )
            })?;
        }
        let m = mode(vals[0], vals[1], vals[2], &at)?;
        let name = cols[0];
        if name.is_empty() {
            return Err(format!("{at}: malformed mode table: empty object name"));
        }
        match objects.iter_mut().find(|o| o.name == name) {
            Some(o) => o.modes.push(m),
            None => objects.push(TableObject {
                name: name.to_owned(),
                modes: vec![m],
            }),
        }
    }
    if let Some(o) = objects.iter().find(|o| o.modes.len() < 2) {
        return Err(format!(
            "object '{}' has {} mode, at least 2 are needed",
            o.name,
            o.modes.len()
        ));
    }
    Ok(objects)
}

/// Reads every table of `inputs` (files only: a folder of tables would mix materials).
pub fn read_all(inputs: &[PathBuf]) -> anyhow::Result<Vec<ModeTable>> {
    inputs
        .iter()
        .map(|p| {
            if p.is_dir() {
                anyhow::bail!(
                    "{}: a folder; name mode tables one by one (a folder of tables may hold several materials)",
                    p.display()
                )
            }
            if !p.exists() {
                anyhow::bail!("{}: no such file", p.display())
            }
            read(p)
        })
        .collect()
}

/// A table object as a fitted recording: its modes (strongest first), no strike noise, no
/// dense partials. Named `<file>#<object>`.
fn as_result(table: &ModeTable, object: &TableObject) -> FileResult {
    let file = short(&table.path);
    let mut modes = object.modes.clone();
    modes.sort_by(|a, b| b.level_db.total_cmp(&a.level_db));
    let none = vec![None; bands::BANDS];
    FileResult {
        name: format!("{file}#{}", object.name),
        fs: 48_000.0,
        modes: modes.clone(),
        ringing: modes,
        ringing_transient: none.clone(),
        dense_transient: None,
        attack_s: 0.0,
        transient: none,
        distance_db: f64::NAN,
        note: String::new(),
        dense: Default::default(),
        // A table's T60s are measured decays, not the end of a cut recording.
        censored: false,
    }
}

fn short(p: &Path) -> String {
    p.file_name()
        .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Variances of PyImpact's draw of a table object, per block of a mode distribution's
/// coordinates (level dB², ln decay², log2 Hz²): `op + N(0, 10 dB)`; `rt + N(0, rt/10)` and
/// `cf + N(0, cf/10)`, a 10 % SD, ≈ 0.1 in ln T60 and 0.1/ln 2 octave.
pub const AUTHORS_VARIANCE: [f64; 3] = [100.0, 0.01, 0.020_813_689_810_056_08];

/// Gives an exemplar component the tables' authors' own spread of one object's modes
/// ([`AUTHORS_VARIANCE`], each mode independent) in place of the few-recordings kernel, keeping
/// any shift common to all frequencies (the size spread over several objects). Why: the
/// authors define how objects drawn from a table vary, and a draw is to sample that spread.
fn authors_kernel(d: &mut crate::preset::ModeDistribution) {
    let n = d.count;
    let cov = &mut d.gaussian.covariance;
    let common = if n > 1 { cov[2 * n][2 * n + 1] } else { 0.0 };
    for i in 0..3 * n {
        cov[i][i] = AUTHORS_VARIANCE[i / n] + if i >= 2 * n { common } else { 0.0 };
    }
}

/// Stores a component's decays as absolute `ln b`, drawn independently of the frequency, in
/// place of deviations from its family's damping law, each mode's mean decay kept. Why: the
/// authors jitter a mode's T60 independently of its frequency; relative to a steep law
/// (ceramic's class-2 law, `α2·ω³`, is 3× its `α1` at 12 kHz) a draw's 10 % frequency jitter
/// would move the mode's decay by up to 30 % more and tie decay to frequency as no table
/// object is, spreading the draws wider than the objects the table stands for.
fn absolute_decays(d: &mut crate::preset::ModeDistribution, law: Option<&crate::preset::DampingModel>) {
    use crate::preset::DecayCoordinates;
    let (DecayCoordinates::DampingResidual, Some(law)) = (d.decay, law) else {
        return;
    };
    let n = d.count;
    for i in 0..n {
        let f = d.gaussian.mean[2 * n + i].exp2();
        d.gaussian.mean[n + i] = (law.residual_base_db_per_s(f) * d.gaussian.mean[n + i].exp()).ln();
    }
    d.decay = DecayCoordinates::Absolute;
}

/// The table objects pooled by [`pool`], as fitted recordings, with their families.
#[derive(Debug, Clone)]
pub struct Pooled {
    /// One per table object, grouped by family.
    pub results: Vec<FileResult>,
    /// The preset.
    pub preset: Preset,
    /// Notes: rows left out, tables repeating another.
    pub notes: Vec<String>,
}

/// Pools `tables` into a preset as [`Pooling::preset`] pools recordings: one exemplar component
/// per table object, grouped into families by size class (each drawn at its class's sizes,
/// [`size_class`]; class 1 left out) or, without size classes, by table file. Where a table lacks
/// what a recording gives, the preset takes a default and its provenance says which and why.
pub fn pool(tables: &[ModeTable], pooling: &Pooling) -> anyhow::Result<Pooled> {
    if pooling.material.trim().is_empty() {
        anyhow::bail!("--material must not be empty");
    }
    if tables.is_empty() {
        anyhow::bail!("no mode table to pool");
    }
    let sized = tables.iter().any(|t| t.size_class.is_some());
    if sized {
        if let Some(t) = tables.iter().find(|t| t.size_class.is_none()) {
            anyhow::bail!(
                "{}: no size class in its name (…_<class>_mm.json) while other tables have one; pool sized and unsized tables separately",
                t.path.display()
            );
        }
    }
    let mut notes: Vec<String> = tables.iter().flat_map(|t| t.notes.clone()).collect();
    for (i, t) in tables.iter().enumerate() {
        if let Some(d) = tables[..i].iter().find(|d| d.objects == t.objects) {
            notes.push(format!("{} repeats {}", short(&t.path), short(&d.path)));
        }
    }
    // Class 1 has no extent (PyImpact never picks it), so no size can draw it.
    let (used, classless): (Vec<&ModeTable>, Vec<&ModeTable>) = tables
        .iter()
        .partition(|t| !sized || t.size_class.and_then(size_class).is_some());
    if !classless.is_empty() {
        notes.push(format!(
            "left out (size class 1, which PyImpact never picks and no extent defines): {}",
            classless
                .iter()
                .map(|t| short(&t.path))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    if used.is_empty() {
        anyhow::bail!(
            "no table of size class 0, 2, 3, 4 or 5: the sizes cannot be mapped (docs/measured.md, \"Size\")"
        );
    }
    // One family per size class (a class's objects together; a table repeated at several
    // classes is one family per class, each sounding at its own class's sizes), else per file.
    let label = |t: &ModeTable| match t.size_class {
        Some(c) => format!("size class {c}"),
        None => short(&t.path),
    };
    let mut order: Vec<String> = Vec::new();
    for t in &used {
        if !order.contains(&label(t)) {
            order.push(label(t));
        }
    }
    let mut results = Vec::new();
    let mut families = Vec::new();
    let mut classes_of = Vec::new();
    for fam in &order {
        for t in used.iter().filter(|t| &label(t) == fam) {
            for o in &t.objects {
                results.push(as_result(t, o));
                families.push(fam.clone());
                classes_of.push(t.size_class.and_then(size_class));
            }
        }
    }
    let objects: Vec<String> = results.iter().map(|r| r.name.clone()).collect();
    let exponent = pooling
        .contact_exponent
        .unwrap_or(crate::engine::force::HC_DEFAULT_EXPONENT);
    let mut preset = assemble(
        pooling,
        &results,
        &Groups {
            families: (order.len() > 1).then_some(families.as_slice()),
            objects: Some(&objects),
        },
        exponent,
    )
    .map_err(|e| anyhow::anyhow!("cannot pool the mode tables into a preset: {e:#}"))?;
    // A table has no strike noise: the pooled transient is the fill of bands never measured.
    preset.transient = None;
    // One family per object, in `results` order.
    for (fam, class) in preset.families.iter_mut().zip(&classes_of) {
        fam.transient = None;
        fam.size_class = *class;
        if let ModeModel::Distribution(d) = &mut fam.modes {
            authors_kernel(d);
            absolute_decays(d, fam.damping.as_ref());
        }
    }
    if let ModeModel::Distribution(d) = &mut preset.modes {
        absolute_decays(d, preset.damping.as_ref());
    }
    let n = results.len();
    preset.origin = Origin::Measured;
    preset.provenance.sources = tables.iter().map(|t| short(&t.path)).collect();
    preset.provenance.method = format!(
        "tactus fit from measured mode tables: each table object (its {OBJECT_ROWS} rows for a JSON table, as PyImpact draws them; its rows for a CSV table) pooled as a fitted recording's ringing modes (levels pre-compensated for the default strike's contact, an exemplar component per object, the family's EMG damping law fitted where one fits), each component spread as PyImpact draws an object from a table (independent SDs of 10 dB in level, 10 % in frequency and in T60, each mode's decay drawn independently of its frequency) in place of the recordings' kernel{}",
        if sized {
            "; objects grouped by size class, each drawn at its class's sizes (docs/measured.md, \"Size\")"
        } else {
            ""
        }
    );
    preset.provenance.notes = format!(
        "{} Defaults taken where a table lacks what a recording gives: no strike noise (transient none: a table lists modes only, and PyImpact plays modes only); no measured contact (contact stiffness the class default, raised as for recordings, levels compensated for the default strike as recordings' are: the tables' levels carry their pellets' strikes as recordings carry their mallets'); no velocity layers (Hunt-Crossley exponent {exponent}, the default); no build-ups, rings or dense fields (a table holds none).{}",
        preset.provenance.notes.replacen(&format!("{n} recordings,"), &format!("{n} table objects,"), 1),
        if notes.is_empty() {
            String::new()
        } else {
            format!(" Table notes: {}.", notes.join("; "))
        }
    );
    preset.validate().map_err(|e| {
        anyhow::anyhow!(
            "the pooled table preset failed its own validation, which is a bug in `tactus fit` ({e})"
        )
    })?;
    Ok(Pooled {
        results,
        preset,
        notes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv(text: &str) -> Result<Vec<TableObject>, String> {
        parse_csv(text)
    }

    #[test]
    fn csv_groups_rows_by_object_and_skips_header_and_comments() {
        let o = csv("object,frequency_hz,level_db,t60_s\n# a mug\nmug,800,-10,0.2\nmug,1900,-20,0.1\n\nbox,300,-5,0.05\nbox,700,-9,0.04\n")
            .unwrap();
        assert_eq!(o.len(), 2);
        assert_eq!(o[0].name, "mug");
        assert_eq!(o[0].modes.len(), 2);
        assert!((o[0].modes[0].decay_db_per_s - 300.0).abs() < 1e-9);
    }

    #[test]
    fn bad_rows_are_named() {
        let e = csv("a,800,-10,-0.2\na,900,-10,0.2\n").unwrap_err();
        assert!(e.contains("line 1") && e.contains("T60"), "{e}");
        let e = csv("a,800,-10,NaN\n").unwrap_err();
        assert!(e.contains("not a finite positive number"), "{e}");
        let e = csv("a,800,-10\n").unwrap_err();
        assert!(e.contains("3 columns"), "{e}");
        let e = csv("a,800,-10,0.1\n").unwrap_err();
        assert!(e.contains("at least 2"), "{e}");
        let e = parse_json(r#"{"cf": [100, 200], "op": [0], "rt": [0.1, 0.1]}"#).unwrap_err();
        assert!(e.contains("differ in length"), "{e}");
        let e = parse_json(r#"{"cf": [100, 200], "op": [0, 0], "rt": [0.1, 0]}"#).unwrap_err();
        assert!(e.contains("row 1") && e.contains("T60"), "{e}");
        let e = parse_json(r#"{"format_version": 7}"#).unwrap_err();
        assert!(e.contains("no \"cf\" array"), "{e}");
    }

    #[test]
    fn long_json_tables_split_into_objects_of_ten_rows() {
        let n = 25;
        let col = |v: f64| vec![v; n];
        let cf: Vec<f64> = (0..n).map(|i| 200.0 + 10.0 * i as f64).collect();
        let text = serde_json::json!({"cf": cf, "op": col(-20.0), "rt": col(0.1)}).to_string();
        let (objects, notes) = parse_json(&text).unwrap();
        assert_eq!(objects.len(), 2);
        assert_eq!(objects[1].name, "rows 10–19");
        assert_eq!(notes.len(), 1, "{notes:?}");
    }

    /// A decay stored relative to a steep law becomes the same mean decay, absolute: the
    /// mean object's modes keep their decays, and a frequency drawn 10 % higher no longer
    /// moves its decay.
    #[test]
    fn table_decays_become_independent_of_the_drawn_frequency() {
        use crate::engine::object::mean_object_modes;
        use crate::preset::{DampingModel, DecayCoordinates, ModeDistribution};
        let mut d: ModeDistribution = serde_json::from_value(serde_json::json!({
            "count": 2,
            "gaussian": {"mean": [-6.0, -10.0, 0.1, -0.2, 10.0, 13.5],
                         "covariance": [[100.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 100.0, 0.0, 0.0, 0.0, 0.0],
                                        [0.0, 0.0, 0.01, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.01, 0.0, 0.0],
                                        [0.0, 0.0, 0.0, 0.0, 0.02, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.02]]},
            "mean_spacing_octaves": 3.5,
            "decay": "damping_residual"
        }))
        .unwrap();
        let law = DampingModel {
            alpha1: 29.0,
            alpha2: 2.0e-13,
            alpha3: 1.5,
            sigma: 0.0,
            eta: 0.0,
        };
        let before = mean_object_modes(&d, Some(&law));
        absolute_decays(&mut d, Some(&law));
        assert_eq!(d.decay, DecayCoordinates::Absolute);
        let after = mean_object_modes(&d, None);
        for (a, b) in before.iter().zip(&after) {
            assert!((a.decay_db_per_s / b.decay_db_per_s - 1.0).abs() < 1e-12);
        }
        // Relative to the law, the upper mode drawn 10 % higher would decay faster.
        let f = 1.1 * 2f64.powf(13.5);
        assert!(law.residual_base_db_per_s(f) / law.residual_base_db_per_s(2f64.powf(13.5)) > 1.2);
    }

    #[test]
    fn size_classes_from_names_and_sizes() {
        assert_eq!(size_class_of(Path::new("x/metal_3_mm.json")), Some(3));
        assert_eq!(size_class_of(Path::new("Ceramic_3_mm.json")), Some(3));
        assert_eq!(size_class_of(Path::new("mug.csv")), None);
        let c2 = size_class(2).unwrap();
        assert!((c2.reference - 1.0).abs() < 1e-12 && c2.covers(1.0) && !c2.covers(0.4));
        assert!(size_class(1).is_none());
        // Adjacent classes meet without a gap, each sounds its table inside the knob's range.
        for w in SIZE_CLASSES.windows(2) {
            assert_eq!(w[0].2, w[1].1);
        }
        for c in SIZE_CLASSES {
            let s = size_class(c.0).unwrap();
            assert!(s.covers(s.reference), "class {}", c.0);
            assert!((KNOB_SIZE_RANGE.0..=KNOB_SIZE_RANGE.1).contains(&s.reference));
        }
    }
}
