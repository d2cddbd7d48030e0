//! Strike speed and brightness (docs/model.md §5, "Strike speed and brightness"). Velocity
//! layers — one object recorded struck softly and hard — show how much brighter a harder strike
//! sounds. The Hunt–Crossley contact's exponent α sets that in the engine: its contact time
//! scales as `v^((1−α)/(1+α))`, so a faster strike is a shorter pulse with more high-frequency
//! energy. [`fit_exponent`] picks the α whose draws brighten from the softest to the hardest
//! layer's speed as much as the recordings do.
//!
//! A layer's speed is what the plugin plays for a MIDI velocity in the middle of the layer's
//! range: `Velocity parameter (1 m/s) × velocity²` ([`crate::plugin::velocity_curve`]). Why the
//! plugin's mapping: the target is that a sound designer's soft and hard notes differ as the
//! recorded layers do.

use crate::analysis::manifest::Manifest;
use crate::analysis::render::{render_mono, Hit};
use crate::engine::Settings;
use crate::preset::Preset;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The plugin's default `Velocity` parameter, m/s (the speed of MIDI velocity 127).
pub const FULL_VELOCITY_M_PER_S: f64 = 1.0;
/// Range of fitted exponents: linear (no brightening) to twice Hertz's 3/2.
pub const EXPONENT_RANGE: (f64, f64) = (1.0, 3.0);
/// Draws per exponent tried: the median log ratio over 8 objects varies by ~0.01 between seed
/// sets, well under the recordings' spread between objects of one family.
const DRAWS: u64 = 8;
/// Bisection steps on α: 10 halve the range to 0.002.
const BISECTION_STEPS: usize = 10;
/// Rendered length of a draw, s: the centroid is a whole-signal measure, and 1.5 s holds all
/// but the slowest partials' tails (the recordings' own centroids come from their whole files).
const RENDER_S: f64 = 1.5;
/// Sample rate of the rendered draws, Hz (as `tactus eval`'s).
const RENDER_FS: f64 = 44_100.0;

/// One object recorded at two strike strengths: its softest and hardest layer.
#[derive(Debug, Clone, PartialEq)]
pub struct LayeredObject {
    /// The manifest's `object_id`.
    pub object_id: String,
    /// Softest and hardest layer's recording.
    pub soft: PathBuf,
    /// See `soft`.
    pub hard: PathBuf,
    /// Speeds the plugin plays those layers at, m/s.
    pub soft_speed_m_per_s: f64,
    /// See `soft_speed_m_per_s`.
    pub hard_speed_m_per_s: f64,
}

/// The speed, m/s, the plugin strikes at for a MIDI velocity `midi_velocity` in 0..1.
pub fn plugin_speed(midi_velocity: f64) -> f64 {
    let v = midi_velocity.clamp(0.0, 1.0);
    FULL_VELOCITY_M_PER_S * v * v
}

struct Layer {
    index: i64,
    path: PathBuf,
    vel_min: f64,
    vel_max: f64,
}

/// The objects recorded in `files` that have at least two velocity layers, from the
/// `manifest.csv` beside each file (columns `file`, `object_id`, `layer_index`, `velocity_min`
/// and `velocity_max`). Every layer the manifest lists for such an object counts, whether or
/// not it is among `files`: a preset may be fitted from one strike per object and still learn
/// how the object brightens. A row with `same_recording_as` set is a gain copy of another
/// layer, not a strike of its own, and is left out, as is a row whose file is missing. Files
/// without such a manifest contribute nothing. A layer's range starts where the layer below
/// ends, as a sampler plays them: some kits write every layer's range from 0.
pub fn layered_objects(files: &[PathBuf]) -> anyhow::Result<Vec<LayeredObject>> {
    let mut by_dir: BTreeMap<PathBuf, Vec<String>> = BTreeMap::new();
    for f in files {
        let dir = f.parent().unwrap_or(Path::new(".")).to_path_buf();
        let name = f
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        by_dir.entry(dir).or_default().push(name);
    }
    let mut out = Vec::new();
    for (dir, names) in by_dir {
        let Some(m) = Manifest::of_folder(&dir)? else {
            continue;
        };
        if !m.has(&["file", "object_id", "layer_index", "velocity_min", "velocity_max"]) {
            continue;
        }
        let mut objects: BTreeMap<String, Vec<Layer>> = BTreeMap::new();
        let mut wanted = std::collections::BTreeSet::new();
        for row in m.rows() {
            let file = row.file();
            if names.iter().any(|n| n == file) {
                wanted.insert(row.get("object_id").to_string());
            }
            if !row.get("same_recording_as").is_empty() || !dir.join(file).is_file() {
                continue;
            }
            let num = |what: &str| -> anyhow::Result<f64> {
                row.get(what)
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        anyhow::anyhow!(
                            "{}: row {} ({file}): {what} '{}' is not a number",
                            m.path.display(),
                            row.line,
                            row.get(what)
                        )
                    })
            };
            let layer = Layer {
                index: num("layer_index")? as i64,
                path: dir.join(file),
                vel_min: num("velocity_min")?,
                vel_max: num("velocity_max")?,
            };
            objects
                .entry(row.get("object_id").to_string())
                .or_default()
                .push(layer);
        }
        for (object_id, mut layers) in objects {
            if !wanted.contains(&object_id) {
                continue;
            }
            layers.sort_by_key(|l| l.index);
            layers.dedup_by_key(|l| l.index);
            if layers.len() < 2 {
                continue;
            }
            let mid = |i: usize| {
                let lo = if i == 0 {
                    layers[0].vel_min
                } else {
                    layers[i].vel_min.max(layers[i - 1].vel_max)
                };
                0.5 * (lo.min(layers[i].vel_max) + layers[i].vel_max)
            };
            let last = layers.len() - 1;
            out.push(LayeredObject {
                object_id,
                soft: layers[0].path.clone(),
                hard: layers[last].path.clone(),
                soft_speed_m_per_s: plugin_speed(mid(0)),
                hard_speed_m_per_s: plugin_speed(mid(last)),
            });
        }
    }
    Ok(out)
}

/// Spectral centroid of `x` from its onset, DC removed, Hz: the evaluation's centroid
/// (`crate::analysis::features::sound_features`); `None` for silence.
pub fn centroid_hz(x: &[f64], fs: f64) -> Option<f64> {
    let y = crate::analysis::signal::from_onset(x);
    if y.iter().all(|v| *v == 0.0) {
        return None;
    }
    crate::analysis::partials::spectral_centroid(&y, fs)
}

/// Hardest over softest layer's spectral centroid of a recorded object ([`centroid_hz`]).
pub fn recorded_ratio(o: &LayeredObject) -> anyhow::Result<f64> {
    let centroid = |p: &Path| -> anyhow::Result<f64> {
        let r = crate::analysis::audio::read_recording(p)?;
        centroid_hz(&r.samples, r.sample_rate)
            .ok_or_else(|| anyhow::anyhow!("{}: silent, no spectral centroid", p.display()))
    };
    Ok(centroid(&o.hard)? / centroid(&o.soft)?)
}

/// One impact at `speed` on the object `Engine::new(preset, 4, seed)` draws, with `settings`,
/// [`RENDER_S`] long at [`RENDER_FS`], as mono `(L + R) / 2`.
pub fn render_hit(preset: &Preset, seed: u64, settings: &Settings, speed: f64) -> Vec<f64> {
    render_mono(
        preset,
        seed,
        &Hit {
            settings,
            speed_m_per_s: speed,
            fs: RENDER_FS,
            seconds: RENDER_S,
            block: 512,
        },
    )
}

/// Median over draws `1..=draws` of `ln(centroid at hard / centroid at soft)` for `preset`
/// at default settings (each draw struck at both speeds). Draws whose renders have no
/// centroid (silent) are skipped; `None` when none has one.
pub fn draws_log_ratio(preset: &Preset, soft: f64, hard: f64, draws: u64) -> Option<f64> {
    use rayon::prelude::*;
    let settings = Settings::default();
    let mut logs: Vec<f64> = (1..=draws)
        .into_par_iter()
        .filter_map(|seed| {
            let c = |v: f64| centroid_hz(&render_hit(preset, seed, &settings, v), RENDER_FS);
            Some((c(hard)? / c(soft)?).ln())
        })
        .filter(|v| v.is_finite())
        .collect();
    if logs.is_empty() {
        return None;
    }
    logs.sort_by(f64::total_cmp);
    Some(crate::stats::median(&logs))
}

/// What [`fit_exponent`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct ExponentFit {
    /// The fitted exponent α.
    pub exponent: f64,
    /// Median of the recordings' hardest/softest centroid ratios.
    pub recorded_ratio: f64,
    /// The draws' ratio at the fitted exponent.
    pub drawn_ratio: f64,
    /// Objects measured.
    pub objects: usize,
}

/// The contact exponent whose draws brighten from the objects' median soft to median hard
/// layer speed as much as the median recorded object does. Bisection on α over
/// [`EXPONENT_RANGE`]: the draws' ratio grows with α (a stiffer-growing contact shortens more
/// with speed). `None` without layered objects.
pub fn fit_exponent(preset: &Preset, objects: &[LayeredObject]) -> anyhow::Result<Option<ExponentFit>> {
    if objects.is_empty() {
        return Ok(None);
    }
    let mut ratios = Vec::new();
    for o in objects {
        ratios.push(recorded_ratio(o)?.ln());
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        crate::stats::median(v)
    };
    let target = med(&mut ratios);
    let soft = med(&mut objects.iter().map(|o| o.soft_speed_m_per_s).collect());
    let hard = med(&mut objects.iter().map(|o| o.hard_speed_m_per_s).collect());
    let at = |alpha: f64| {
        let p = Preset {
            contact_exponent: alpha,
            ..preset.clone()
        };
        draws_log_ratio(&p, soft, hard, DRAWS).unwrap_or(0.0)
    };
    let (mut lo, mut hi) = EXPONENT_RANGE;
    let (r_lo, r_hi) = (at(lo), at(hi));
    let (alpha, drawn) = if target <= r_lo {
        (lo, r_lo)
    } else if target >= r_hi {
        (hi, r_hi)
    } else {
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if at(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // Rounded so the preset file states it plainly.
        let a = (500.0 * (lo + hi)).round() / 1000.0;
        (a, at(a))
    };
    Ok(Some(ExponentFit {
        exponent: alpha,
        recorded_ratio: target.exp(),
        drawn_ratio: drawn.exp(),
        objects: objects.len(),
    }))
}
