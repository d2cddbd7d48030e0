//! The measured materials (docs/measured.md): each one's draws, at the size the plugin plays a
//! size class at, fall inside the spread of that class's table as its authors draw it
//! (PyImpact: each of the first ten rows jittered, `cf + N(0, cf/10)`, `op + N(0, 10 dB)`,
//! `rt + N(0, rt/10)`; played by the same strike as the draws); and mode tables that are malformed or
//! hold a non-finite or negative decay are refused with an error naming them.

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use std::path::{Path, PathBuf};
use tactus::analysis::features::sound_features;
use tactus::analysis::render::{render_mono, Hit};
use tactus::engine::materials::{measured_presets, MEASURED_PRESET_NAMES};
use tactus::engine::Settings;
use tactus::fit::pool::distribution::ContactCompensation;
use tactus::fit::table::{size_class, SIZE_CLASSES};
use tactus::preset::{FixedMode, ModeModel, Preset};
use tactus::stats::{median, quantile};

/// PyImpact's names of the measured materials, in [`MEASURED_PRESET_NAMES`] order.
const PYIMPACT: [&str; 14] = [
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
const FS: f64 = 44_100.0;
const SECONDS: f64 = 1.0;
/// Renders of a table as PyImpact draws it (its spread) and draws of the preset (their median).
const TABLE_RENDERS: usize = 16;
const DRAWS: usize = 7;

/// `$TACTUS_MEASURED/materials`, else `../shared/measured/materials`; `None` with a SKIPPED line.
fn tables_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("TACTUS_MEASURED")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/measured"))
        .join("materials");
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!(
            "SKIPPED: mode tables {} not found (set TACTUS_MEASURED)",
            dir.display()
        );
        None
    }
}

/// The first ten rows of table `<py>_<class>_mm.json` (PyImpact ships ceramic's class 3 as
/// `Ceramic_3_mm.json`): (cf Hz, op dB, rt s).
fn table_rows(dir: &Path, py: &str, class: u8) -> Vec<(f64, f64, f64)> {
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
    let v: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())),
    )
    .unwrap();
    let col = |k: &str| -> Vec<f64> {
        v[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (cf, op, rt) = (col("cf"), col("op"), col("rt"));
    (0..10).map(|i| (cf[i], op[i], rt[i])).collect()
}

/// One object drawn from `rows` as PyImpact draws it (`_get_object_modes`: each of the first
/// ten rows jittered independently), as a fixed-mode preset played by `base`'s default strike:
/// levels raised by the strike's contact compensation as the fit raises them, strongest at
/// −6 dB. Why through the engine and not PyImpact's own renderer: the centroid of a struck
/// mode's spectrum depends on its onset (PyImpact starts each mode as a full-amplitude cosine,
/// a click whose skirt lifts the centroid by up to 2×; a strike's contact shapes the engine's),
/// so rendered alike, the two sides differ only in how their modes are drawn.
fn table_object(base: &Preset, rows: &[(f64, f64, f64)], rng: &mut rand::rngs::StdRng) -> Preset {
    let unit = Normal::new(0.0, 1.0).unwrap();
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
        .filter(|m| m.freq_hz < 0.45 * FS)
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

/// (centroid Hz, T60 s) of `x`; `None` when it has no features.
fn feats(x: &[f64]) -> Option<(f64, f64)> {
    sound_features(x, FS).ok().map(|f| (f.centroid_hz, f.t60_s))
}

/// One check: material, class, feature, the draws' median, the table's 10 % and 90 % points.
type Check = (usize, u8, &'static str, f64, f64, f64);

/// Every material's draws against its tables, per size class and feature, computed once per
/// test run (both tests below read it); `None` without the tables.
fn checks() -> Option<&'static [Check]> {
    use rayon::prelude::*;
    static CHECKS: std::sync::OnceLock<Option<Vec<Check>>> = std::sync::OnceLock::new();
    CHECKS
        .get_or_init(|| {
            let dir = tables_dir()?;
            let presets = measured_presets();
            assert_eq!(presets.len(), PYIMPACT.len());
            let cases: Vec<(usize, u8)> = (0..PYIMPACT.len())
                .flat_map(|m| SIZE_CLASSES.iter().map(move |c| (m, c.0)))
                .collect();
            Some(
                cases
                    .par_iter()
                    .flat_map_iter(|&(m, class)| {
                        let rows = table_rows(&dir, PYIMPACT[m], class);
                        let mut rng = rand::rngs::StdRng::seed_from_u64(1000 + m as u64 * 10 + u64::from(class));
                        let plain = Hit::default_for(SECONDS);
                        let table: Vec<(f64, f64)> = (0..TABLE_RENDERS as u64)
                            .filter_map(|seed| feats(&render_mono(&table_object(&presets[m], &rows, &mut rng), seed, &plain)))
                            .collect();
                        let size = size_class(class).unwrap().reference;
                        let settings = at_size(size);
                        let hit = Hit {
                            settings: &settings,
                            ..Hit::default_for(SECONDS)
                        };
                        let draws: Vec<(f64, f64)> = (0..DRAWS as u64)
                            .filter_map(|seed| feats(&render_mono(&presets[m], seed, &hit)))
                            .collect();
                        assert!(
                            table.len() >= TABLE_RENDERS / 2 && draws.len() >= DRAWS / 2,
                            "{} class {class}: {} table objects and {} draws have features",
                            MEASURED_PRESET_NAMES[m],
                            table.len(),
                            draws.len()
                        );
                        [("centroid", 0), ("T60", 1)].map(|(what, pick)| {
                            let get = |v: &[(f64, f64)]| -> Vec<f64> {
                                v.iter().map(|p| if pick == 0 { p.0 } else { p.1 }).collect()
                            };
                            let (t, d) = (get(&table), get(&draws));
                            let check = (m, class, what, median(&d), quantile(&t, 0.1), quantile(&t, 0.9));
                            eprintln!(
                                "{:<28} class {class} size {size:6.3}: {what:<8} draws' median {:9.3}, table 10–90 % {:9.3}–{:9.3}",
                                MEASURED_PRESET_NAMES[m], check.3, check.4, check.5
                            );
                            check
                        })
                    })
                    .collect(),
            )
        })
        .as_deref()
}

/// The checks of `feature` whose draws' median lies outside the table's 10–90 % range.
fn outside(checks: &[Check], feature: &str) -> Vec<String> {
    checks
        .iter()
        .filter(|c| c.2 == feature && !(c.3 >= c.4 && c.3 <= c.5))
        .map(|c| {
            format!(
                "{} class {}: {feature} median {:.3} outside {:.3}–{:.3}",
                MEASURED_PRESET_NAMES[c.0], c.1, c.3, c.4, c.5
            )
        })
        .collect()
}

#[test]
fn measured_draws_ring_as_long_as_their_tables_per_size_class() {
    let Some(checks) = checks() else {
        return;
    };
    let bad = outside(checks, "T60");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
#[ignore = "target not met yet: 7 of 70 centroid medians lie above their tables' 90 % point, none below (docs/measured.md)"]
fn measured_draws_are_as_bright_as_their_tables_per_size_class() {
    let Some(checks) = checks() else {
        return;
    };
    let bad = outside(checks, "centroid");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The default settings with the object at `size`.
fn at_size(size: f64) -> Settings {
    Settings {
        impact: tactus::engine::ImpactSettings {
            size,
            ..Settings::default().impact
        },
        ..Settings::default()
    }
}

#[test]
fn a_size_class_draws_its_own_table() {
    // Metal's class-0 table rings around 4.7 kHz, its class-3 table around 0.7 kHz (the
    // README's 5.6 → 1.0 kHz by median row): drawn at the sizes that play them, the draws keep
    // the order, and a size inside class 3 draws the class-3 object whatever size drew before.
    let metal = &measured_presets()[3];
    let centroid_at = |size: f64| {
        let settings = at_size(size);
        let hit = Hit {
            settings: &settings,
            ..Hit::default_for(SECONDS)
        };
        median(
            &(0..5)
                .filter_map(|s| feats(&render_mono(metal, s, &hit)).map(|f| f.0))
                .collect::<Vec<_>>(),
        )
    };
    let (small, large) = (
        centroid_at(size_class(0).unwrap().reference),
        centroid_at(size_class(3).unwrap().reference),
    );
    assert!(
        small > 3.0 * large,
        "class 0 {small:.0} Hz, class 3 {large:.0} Hz"
    );
}

fn fit_cli(dir: &Path, files: &[&str], contents: &[&str]) -> std::process::Output {
    let paths: Vec<PathBuf> = files
        .iter()
        .zip(contents)
        .map(|(f, c)| {
            let p = dir.join(f);
            std::fs::write(&p, c).unwrap();
            p
        })
        .collect();
    std::process::Command::new(env!("CARGO_BIN_EXE_tactus"))
        .arg("fit")
        .args(&paths)
        .args(["--material", "glass", "-o"])
        .arg(dir.join("out.json"))
        .output()
        .unwrap()
}

#[test]
fn bad_mode_tables_are_refused_naming_the_file() {
    let dir = std::env::temp_dir().join(format!("tactus-tables-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let cases: [(&str, &str, &[&str]); 5] = [
        (
            "neg.csv",
            "jar,800,-10,0.2\njar,1700,-12,-0.1\n",
            &["neg.csv", "line 2", "T60"],
        ),
        (
            "nan.json",
            r#"{"cf": [800, 1700], "op": [-10, -12], "rt": [0.2, NaN]}"#,
            &["nan.json", "not valid JSON"],
        ),
        (
            "inf.csv",
            "jar,800,-10,inf\njar,1700,-12,0.1\n",
            &["inf.csv", "line 1", "not a finite positive number"],
        ),
        (
            "short.json",
            r#"{"cf": [800, 1700], "op": [-10], "rt": [0.2, 0.1]}"#,
            &["short.json", "differ in length"],
        ),
        ("cols.csv", "jar,800,-10\n", &["cols.csv", "3 columns"]),
    ];
    for (file, text, needles) in cases {
        let out = fit_cli(&dir, &[file], &[text]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{file}: accepted");
        assert_eq!(err.trim_end().lines().count(), 1, "{file}: not one line: {err}");
        for n in needles {
            assert!(err.contains(n), "{file}: '{n}' not in: {err}");
        }
    }
    // A good CSV table pools into a measured preset saying which defaults it took.
    let out = fit_cli(
        &dir,
        &["jars.csv"],
        &["object,frequency_hz,level_db,t60_s\njar1,800,-10,0.2\njar1,1900,-14,0.12\njar1,3100,-20,0.08\njar2,850,-9,0.18\njar2,2000,-15,0.1\njar2,3300,-22,0.07\n"],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let p = tactus::preset::Preset::load(&dir.join("out.json")).unwrap();
    assert_eq!(p.origin, tactus::preset::Origin::Measured);
    assert!(p.transient.is_none() && p.families.iter().all(|f| f.transient.is_none()));
    assert!(
        p.provenance.notes.contains("Defaults taken"),
        "{}",
        p.provenance.notes
    );
    assert_eq!(p.families.len(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn preset_list_names_every_material_and_scenes_take_them() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_tactus"))
        .args(["preset", "list", "--json"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let list: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let list = list.as_array().unwrap();
    let shipped = tactus::engine::materials::shipped_presets();
    assert_eq!(list.len(), shipped.len());
    for (l, p) in list.iter().zip(&shipped) {
        let name = l["name"].as_str().unwrap();
        assert_eq!(name, p.name);
        let origin = l["origin"].as_str().unwrap();
        assert!(
            ["recordings", "measured mode tables", "derived"].contains(&origin),
            "{name}: {origin}"
        );
        assert!(!l["sources"].as_array().unwrap().is_empty(), "{name}: no source");
        assert!(!l["class"].as_str().unwrap().is_empty());
        // A scene's material takes the listed name and resolves to that very preset.
        assert_eq!(
            tactus::scene::builtin_material(name).map(|q| q.name),
            Some(p.name.clone()),
            "{name}"
        );
        // The plugin's material parameter holds it at the listed index.
        assert_eq!(
            tactus::plugin::params::material_name(l["index"].as_i64().unwrap() as i32),
            name
        );
    }
    for m in MEASURED_PRESET_NAMES {
        assert!(
            list.iter()
                .any(|l| l["name"] == m && l["origin"] == "measured mode tables"),
            "{m}"
        );
    }
    let text = std::process::Command::new(env!("CARGO_BIN_EXE_tactus"))
        .args(["preset", "list"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&text.stdout);
    assert_eq!(text.lines().count(), shipped.len() + 1, "{text}");
}
