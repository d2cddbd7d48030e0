//! The measured materials against their mode tables (docs/measured.md): the tables' own
//! renderings (an object drawn from a table as its authors draw it, PyImpact's
//! `_get_object_modes`: each of the first ten rows jittered independently, `cf + N(0, cf/10)`,
//! `op + N(0, 10 dB)`, `rt + N(0, rt/10)`) and the presets' draws, both played by the preset's
//! default strike at the size that plays the table's class, measured by the evaluation's one
//! feature function ([`sound_features`]); and a nearest-centre classifier trained on the table
//! renderings that judges both (14-way material and hard/soft class).
//!
//! Why both sides through the engine and not PyImpact's renderer: a struck mode's spectral
//! centroid depends on its onset (PyImpact starts each mode as a full-amplitude cosine, a click
//! whose skirt lifts the centroid by up to 2×; a strike's contact shapes the engine's), so
//! played alike the two sides differ only in how their modes are drawn.

use super::classifier::Classifier;
use super::confusion::Confusion;
use crate::analysis::features::{sound_features, SoundFeatures};
use crate::analysis::render::{render_mono, Hit, RENDER_FS};
use crate::engine::materials::{measured_presets, MEASURED_PRESET_NAMES};
use crate::engine::Settings;
use crate::fit::pool::distribution::ContactCompensation;
use crate::fit::table::{size_class, SIZE_CLASSES};
use crate::preset::{FixedMode, ModeModel, Preset};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use std::path::Path;

/// PyImpact's names of the measured materials, in [`MEASURED_PRESET_NAMES`] order.
pub const PYIMPACT_NAMES: [&str; 14] = [
    "ceramic",
    "glass",
    "stone",
    "metal",
    "wood_hard",
    "wood_medium",
    "wood_soft",
    "plastic_hard",
    "plastic_soft_foam",
    "rubber",
    "cardboard",
    "paper",
    "leather",
    "fabric",
];

/// The hard materials of the hard/soft split (the rest are soft).
pub const HARD: [&str; 4] = ["ceramic", "glass", "stone", "metal"];

/// Whether PyImpact material `py` is hard ([`HARD`]).
pub fn is_hard(py: &str) -> bool {
    HARD.contains(&py)
}

/// Length of every rendering, s: the tables ring 0.02–0.4 s, so 1 s holds every decay.
pub const SECONDS: f64 = 1.0;

/// Rows PyImpact draws an object from: the first ten of a table.
const ROWS: usize = 10;

/// The first ten rows of table `<py>_<class>_mm.json` in `dir` (PyImpact ships ceramic's
/// class 3 as `Ceramic_3_mm.json`): (cf Hz, op dB, rt s).
pub fn table_rows(dir: &Path, py: &str, class: u8) -> anyhow::Result<Vec<(f64, f64, f64)>> {
    let mut path = dir.join(format!("{py}_{class}_mm.json"));
    if !path.exists() {
        let mut c = py.chars();
        let cap: String = c
            .next()
            .map(|f| f.to_ascii_uppercase())
            .into_iter()
            .chain(c)
            .collect();
        path = dir.join(format!("{cap}_{class}_mm.json"));
    }
    let text = std::fs::read_to_string(&path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let col = |k: &str| -> anyhow::Result<Vec<f64>> {
        v[k].as_array()
            .ok_or_else(|| anyhow::anyhow!("{}: no \"{k}\" array", path.display()))?
            .iter()
            .map(|x| {
                x.as_f64()
                    .ok_or_else(|| anyhow::anyhow!("{}: \"{k}\" holds {x}", path.display()))
            })
            .collect()
    };
    let (cf, op, rt) = (col("cf")?, col("op")?, col("rt")?);
    if cf.len() < ROWS || op.len() < ROWS || rt.len() < ROWS {
        anyhow::bail!("{}: fewer than {ROWS} rows", path.display());
    }
    Ok((0..ROWS).map(|i| (cf[i], op[i], rt[i])).collect())
}

/// One object drawn from `rows` as PyImpact draws it, as a fixed-mode preset played by `base`'s
/// default strike: levels raised by the strike's contact compensation as the fit raises them
/// (the tables' levels, like recordings', carry their strikes), strongest at −6 dB, modes above
/// 0.45 × [`RENDER_FS`] left out.
pub fn table_object(base: &Preset, rows: &[(f64, f64, f64)], rng: &mut rand::rngs::StdRng) -> Preset {
    let unit = Normal::new(0.0, 1.0).expect("unit normal");
    let contact = ContactCompensation::default_strike(base.contact_stiffness_n_per_m, base.contact_exponent);
    let mut modes: Vec<FixedMode> = rows
        .iter()
        .map(|&(cf, op, rt)| {
            let f = loop {
                let f = cf + unit.sample(rng) * cf / 10.0;
                if f >= 20.0 {
                    break f;
                }
            };
            let p = op + 10.0 * unit.sample(rng);
            let t60 = loop {
                let t = rt + unit.sample(rng) * rt / 10.0;
                if t >= 0.001 {
                    break t;
                }
            };
            FixedMode {
                freq_hz: f,
                level_db: p + contact.boost_db(f),
                decay_db_per_s: 60.0 / t60,
                rise_s: 0.0,
                ring: Default::default(),
            }
        })
        .filter(|m| m.freq_hz < 0.45 * RENDER_FS)
        .collect();
    let top = modes.iter().map(|m| m.level_db).fold(f64::NEG_INFINITY, f64::max);
    for m in &mut modes {
        m.level_db += -6.0 - top;
    }
    Preset {
        modes: ModeModel::Fixed { modes },
        families: Vec::new(),
        transient: None,
        dense: None,
        ..base.clone()
    }
}

/// The default settings with the object at `size`.
pub fn at_size(size: f64) -> Settings {
    Settings {
        impact: crate::engine::ImpactSettings {
            size,
            ..Settings::default().impact
        },
        ..Settings::default()
    }
}

/// Seed of the generator that draws the table objects of material `m`, class `class`.
pub fn table_seed(m: usize, class: u8) -> u64 {
    1000 + m as u64 * 10 + u64::from(class)
}

/// Seed of draw `k` at size class `class`. Why per class: classes that repeat one table are
/// one distribution, and with the same seeds they would play the very same objects, so one
/// unlucky set of draws would count against every class of the table.
pub fn draw_seed(class: u8, k: u64) -> u64 {
    1000 * u64::from(class) + k
}

/// Table object `k` of material `m`, class `class` ([`table_object`] with [`table_seed`]'s
/// generator after `k` objects), rendered by a default hit: the tables' own rendering.
pub fn render_table(preset: &Preset, rows: &[(f64, f64, f64)], m: usize, class: u8, k: usize) -> Vec<f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(table_seed(m, class));
    let mut obj = table_object(preset, rows, &mut rng);
    for _ in 0..k {
        obj = table_object(preset, rows, &mut rng);
    }
    render_mono(&obj, k as u64, &Hit::default_for(SECONDS))
}

/// Draw `seed` of `preset` at the size that plays size class `class`, by a default hit.
pub fn render_class_draw(preset: &Preset, class: u8, seed: u64) -> Vec<f64> {
    let size = size_class(class).map_or(1.0, |c| c.reference);
    let settings = at_size(size);
    let hit = Hit {
        settings: &settings,
        ..Hit::default_for(SECONDS)
    };
    render_mono(preset, seed, &hit)
}

/// One material's size class: its table renderings' and its draws' features (those that have
/// features).
#[derive(Debug, Clone)]
pub struct ClassSounds {
    /// Index into [`PYIMPACT_NAMES`] and [`MEASURED_PRESET_NAMES`].
    pub material: usize,
    /// PyImpact size class.
    pub class: u8,
    /// The size the draws were played at.
    pub size: f64,
    /// The table's own renderings.
    pub table: Vec<SoundFeatures>,
    /// The preset's draws.
    pub draws: Vec<SoundFeatures>,
}

/// Every measured material at every size class ([`SIZE_CLASSES`]): `table_renders` objects
/// drawn from the class's table (in `materials_dir`) and draws `0..draws` of the shipped preset,
/// rendered and measured in parallel (draw `k` with [`draw_seed`]).
pub fn measure_all(
    materials_dir: &Path,
    table_renders: usize,
    draws: usize,
) -> anyhow::Result<Vec<ClassSounds>> {
    let presets = measured_presets();
    let cases: Vec<(usize, u8)> = (0..PYIMPACT_NAMES.len())
        .flat_map(|m| SIZE_CLASSES.iter().map(move |c| (m, c.0)))
        .collect();
    let rows: Vec<Vec<(f64, f64, f64)>> = cases
        .iter()
        .map(|&(m, c)| table_rows(materials_dir, PYIMPACT_NAMES[m], c))
        .collect::<anyhow::Result<_>>()?;
    let feats = |x: Vec<f64>| sound_features(&x, RENDER_FS).ok();
    Ok(cases
        .par_iter()
        .zip(&rows)
        .map(|(&(m, class), rows)| {
            let mut rng = rand::rngs::StdRng::seed_from_u64(table_seed(m, class));
            let plain = Hit::default_for(SECONDS);
            let table = (0..table_renders as u64)
                .filter_map(|k| feats(render_mono(&table_object(&presets[m], rows, &mut rng), k, &plain)))
                .collect();
            let draws = (0..draws as u64)
                .filter_map(|k| feats(render_class_draw(&presets[m], class, draw_seed(class, k))))
                .collect();
            ClassSounds {
                material: m,
                class,
                size: size_class(class).map_or(1.0, |c| c.reference),
                table,
                draws,
            }
        })
        .collect())
}

/// How often the classifier recognises the tables' renderings (each left out of its own
/// training) and the presets' draws (judged by the classifier trained on every rendering).
#[derive(Debug, Clone)]
pub struct Recognition {
    /// 14-way material, table renderings left out one at a time.
    pub table_material: Confusion,
    /// 14-way material, the presets' draws.
    pub draws_material: Confusion,
    /// Hard/soft, table renderings left out one at a time.
    pub table_hardness: Confusion,
    /// Hard/soft, the presets' draws.
    pub draws_hardness: Confusion,
}

/// The classifier of the measured materials: a centre per material and size class (a
/// material's classes differ in pitch and decay as much as materials do, so one mean per
/// material would sit between them, [`super::classifier`]'s reason), trained on the table
/// renderings in `sounds`, skipping the one at (`skip_class`, `skip_index`).
fn train(sounds: &[ClassSounds], skip: Option<(usize, usize)>) -> Classifier {
    let families: Vec<String> = sounds.iter().map(|s| format!("class {}", s.class)).collect();
    let samples = sounds.iter().enumerate().flat_map(|(i, s)| {
        let fam = families[i].as_str();
        s.table
            .iter()
            .enumerate()
            .filter(move |(k, _)| skip != Some((i, *k)))
            .map(move |(_, f)| (PYIMPACT_NAMES[s.material], fam, f))
    });
    Classifier::train(samples).expect("14 materials")
}

/// Counts one judgement of a sound of material `truth` judged `predicted` (PyImpact names)
/// into the material and hard/soft matrices.
fn count(material: &mut Confusion, hardness: &mut Confusion, truth: usize, predicted: &str) {
    let p = PYIMPACT_NAMES.iter().position(|n| *n == predicted).unwrap_or(0);
    material.add(truth, p);
    let h = |py: &str| usize::from(!is_hard(py));
    hardness.add(h(PYIMPACT_NAMES[truth]), h(predicted));
}

/// The recognition of the tables' renderings (left out one at a time) and of the presets'
/// draws by the nearest-centre classifier trained on the renderings (decay and spectrum
/// features, [`SoundFeatures::vector`]). The hard/soft judgement is that of the nearest
/// centre's material.
pub fn recognition(sounds: &[ClassSounds]) -> Recognition {
    let names: Vec<&str> = PYIMPACT_NAMES.to_vec();
    let mut r = Recognition {
        table_material: Confusion::new(&names),
        draws_material: Confusion::new(&names),
        table_hardness: Confusion::new(&["hard", "soft"]),
        draws_hardness: Confusion::new(&["hard", "soft"]),
    };
    let left_out: Vec<(usize, String)> = sounds
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, s)| {
            (0..s.table.len()).map(move |k| {
                let c = train(sounds, Some((i, k)));
                (s.material, c.classify(&s.table[k]).to_owned())
            })
        })
        .collect();
    for (truth, p) in &left_out {
        count(&mut r.table_material, &mut r.table_hardness, *truth, p);
    }
    let all = train(sounds, None);
    for s in sounds {
        for f in &s.draws {
            count(
                &mut r.draws_material,
                &mut r.draws_hardness,
                s.material,
                all.classify(f),
            );
        }
    }
    r
}

/// Short column heads for the material matrix: PyImpact's names abbreviated.
pub fn short_name(py: &str) -> String {
    match py {
        "wood_hard" => "wH".into(),
        "wood_medium" => "wM".into(),
        "wood_soft" => "wS".into(),
        "plastic_hard" => "plH".into(),
        "plastic_soft_foam" => "foam".into(),
        "cardboard" => "card".into(),
        "leather" => "lea".into(),
        "ceramic" => "cer".into(),
        "rubber" => "rub".into(),
        "fabric" => "fab".into(),
        "metal" => "met".into(),
        "glass" => "gla".into(),
        "stone" => "sto".into(),
        "paper" => "pap".into(),
        other => other.to_owned(),
    }
}

/// The display name of PyImpact material `py` ([`MEASURED_PRESET_NAMES`]).
pub fn preset_name(py: &str) -> &'static str {
    PYIMPACT_NAMES
        .iter()
        .position(|n| *n == py)
        .map_or("", |i| MEASURED_PRESET_NAMES[i])
}

/// Size class of the materials' contact sheets: class 2, the hand-sized objects size 1 plays.
pub const SHEET_CLASS: u8 = 2;

/// Materials per contact sheet (one per row: the table's rendering, then a draw).
pub const SHEET_MATERIALS: usize = 7;

/// Writes the materials' contact sheets into `out_dir` (`measured-materials-1.png`, …): per
/// material at [`SHEET_CLASS`], the table's own rendering (its first object) beside the
/// preset's draw 1, each played by a default hit. Returns the files written.
pub fn write_material_sheets(
    materials_dir: &Path,
    out_dir: &Path,
) -> anyhow::Result<Vec<std::path::PathBuf>> {
    use super::spectrogram::{write_grid, Layout, Panel};
    let presets = measured_presets();
    let sounds: Vec<(String, Vec<f64>, String, Vec<f64>)> = (0..PYIMPACT_NAMES.len())
        .into_par_iter()
        .map(|m| {
            let rows = table_rows(materials_dir, PYIMPACT_NAMES[m], SHEET_CLASS)?;
            Ok((
                format!("{}_{SHEET_CLASS}_mm.json, authors' draw", PYIMPACT_NAMES[m]),
                render_table(&presets[m], &rows, m, SHEET_CLASS, 0),
                format!("{}, draw 1", MEASURED_PRESET_NAMES[m]),
                render_class_draw(&presets[m], SHEET_CLASS, 1),
            ))
        })
        .collect::<anyhow::Result<_>>()?;
    let layout = Layout {
        columns: 2,
        span_s: 0.5,
        band_hz: (50.0, 16_000.0),
        panel_px: (360, 280),
    };
    let mut written = Vec::new();
    for (k, chunk) in sounds.chunks(SHEET_MATERIALS).enumerate() {
        let panels: Vec<Panel> = chunk
            .iter()
            .flat_map(|(ta, a, tb, b)| {
                [
                    Panel {
                        title: ta.clone(),
                        samples: a,
                        fs: RENDER_FS,
                    },
                    Panel {
                        title: tb.clone(),
                        samples: b,
                        fs: RENDER_FS,
                    },
                ]
            })
            .collect();
        let path = out_dir.join(format!("measured-materials-{}.png", k + 1));
        write_grid(
            &path,
            "Measured materials, size class 2: the table's own rendering (left) and a draw (right), default hit",
            &panels,
            &layout,
        )?;
        written.push(path);
    }
    Ok(written)
}
