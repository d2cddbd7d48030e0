//! Offline scenes: the JSON format `tactus render` reads (documented in the README), parsing
//! with readable errors, and the renderer that turns a scene into audio through the engine.

use crate::engine::force::ContactModel;
use crate::engine::{materials, Engine, Event, Settings};
use crate::preset::Preset;
use serde::Deserialize;
use std::path::Path;

/// The embedded demo scene (`tactus render --demo`).
pub const DEMO_SCENE: &str = include_str!("../scenes/demo.json");

/// Longest scene accepted, in seconds (one hour): a guard against typos like 36000.
pub const MAX_DURATION_S: f64 = 3600.0;

/// Which material a scene uses: a built-in name or a preset file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum MaterialRef {
    /// Built-in material by name (case-insensitive), e.g. "wood".
    Name(String),
    /// A preset file, relative to the scene file.
    File {
        /// Path to a preset JSON.
        preset_file: String,
    },
}

/// Engine settings as written in a scene; every field optional (defaults from [`Settings`]).
#[derive(Debug, Clone, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneSettings {
    /// Object scale (1 = reference).
    pub size: Option<f64>,
    /// Decay multiplier.
    pub damping: Option<f64>,
    /// Striker mass, kg.
    pub mass_kg: Option<f64>,
    /// Stiffness multiplier.
    pub hardness: Option<f64>,
    /// "spring", "raised_cosine" or "hunt_crossley".
    pub contact_model: Option<ContactModel>,
    /// Re-hit variation (0.2 = Traer).
    pub variation: Option<f64>,
    /// Culling threshold, dB below the strongest mode.
    pub quality_db: Option<f64>,
    /// Output gain, dB.
    pub gain_db: Option<f64>,
}

/// One timed event.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SceneEvent {
    /// An impact at `time_s`.
    Impact {
        /// Time in s.
        time_s: f64,
        /// Impact speed, m/s (default 1).
        #[serde(default = "one")]
        velocity_m_per_s: f64,
        /// Frequency factor for this hit (default 1).
        #[serde(default = "one")]
        pitch: f64,
    },
    /// Draw a new object from the material at `time_s`.
    NewObject {
        /// Time in s.
        time_s: f64,
        /// Seed of the new object.
        seed: u64,
    },
}

fn one() -> f64 {
    1.0
}

impl SceneEvent {
    fn time_s(&self) -> f64 {
        match self {
            SceneEvent::Impact { time_s, .. } | SceneEvent::NewObject { time_s, .. } => *time_s,
        }
    }
}

/// A scene file.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Output sample rate, Hz (default 48000).
    #[serde(default = "default_sr")]
    pub sample_rate: u32,
    /// Length of the render, s.
    pub duration_s: f64,
    /// Seed of the first object and of per-hit variation (default 1).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Material.
    pub material: MaterialRef,
    /// Engine settings.
    #[serde(default)]
    pub settings: SceneSettings,
    /// Timed events.
    #[serde(default)]
    pub events: Vec<SceneEvent>,
}

fn default_sr() -> u32 {
    48_000
}

fn default_seed() -> u64 {
    1
}

/// A scene made ready to render: parsed, validated, material resolved.
#[derive(Debug, Clone)]
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// Its resolved material.
    pub preset: Preset,
}

/// Looks up a built-in material by name, case-insensitively.
pub fn builtin_material(name: &str) -> Option<Preset> {
    materials::builtin_presets()
        .into_iter()
        .find(|p| p.name.eq_ignore_ascii_case(name) || p.material_class.eq_ignore_ascii_case(name))
}

impl Scene {
    /// Parses and validates scene JSON. `base` resolves relative preset paths.
    pub fn parse(text: &str, base: Option<&Path>) -> anyhow::Result<LoadedScene> {
        let scene: Scene =
            serde_json::from_str(text).map_err(|e| anyhow::anyhow!("invalid scene JSON: {e}"))?;
        if !(8_000..=384_000).contains(&scene.sample_rate) {
            anyhow::bail!(
                "scene: sample_rate {} Hz is outside 8000..=384000",
                scene.sample_rate
            );
        }
        if !scene.duration_s.is_finite() || scene.duration_s <= 0.0 {
            anyhow::bail!(
                "scene: duration_s must be a positive number of seconds, got {}",
                scene.duration_s
            );
        }
        if scene.duration_s > MAX_DURATION_S {
            anyhow::bail!(
                "scene: duration_s {} exceeds the maximum of {MAX_DURATION_S} s",
                scene.duration_s
            );
        }
        for (i, e) in scene.events.iter().enumerate() {
            let t = e.time_s();
            if !t.is_finite() || t < 0.0 {
                anyhow::bail!("scene: events[{i}].time_s must be ≥ 0, got {t}");
            }
            if let SceneEvent::Impact {
                velocity_m_per_s,
                pitch,
                ..
            } = e
            {
                if !velocity_m_per_s.is_finite() || *velocity_m_per_s < 0.0 || *velocity_m_per_s > 100.0 {
                    anyhow::bail!(
                        "scene: events[{i}].velocity_m_per_s must be in 0..=100 m/s, got {velocity_m_per_s}"
                    );
                }
                if !pitch.is_finite() || *pitch <= 0.0 {
                    anyhow::bail!("scene: events[{i}].pitch must be a positive factor, got {pitch}");
                }
            }
        }
        let preset = match &scene.material {
            MaterialRef::Name(n) => builtin_material(n).ok_or_else(|| {
                let names: Vec<String> = materials::builtin_presets().into_iter().map(|p| p.name).collect();
                anyhow::anyhow!("scene: unknown material '{n}' (available: {})", names.join(", "))
            })?,
            MaterialRef::File { preset_file } => {
                let p = match base {
                    Some(b) => b.join(preset_file),
                    None => preset_file.into(),
                };
                Preset::load(&p)?
            }
        };
        Ok(LoadedScene { scene, preset })
    }

    /// Reads and parses a scene file.
    pub fn load(path: &Path) -> anyhow::Result<LoadedScene> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("cannot read scene {}: {e}", path.display()))?;
        Scene::parse(&text, path.parent()).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// Engine settings of this scene.
    pub fn settings(&self) -> Settings {
        let d = Settings::default();
        let s = &self.settings;
        Settings {
            size: s.size.unwrap_or(d.size),
            damping: s.damping.unwrap_or(d.damping),
            mass_kg: s.mass_kg.unwrap_or(d.mass_kg),
            hardness: s.hardness.unwrap_or(d.hardness),
            contact_model: s.contact_model.unwrap_or(d.contact_model),
            variation: s.variation.unwrap_or(d.variation),
            quality_db: s.quality_db.unwrap_or(d.quality_db),
            gain_db: s.gain_db.unwrap_or(d.gain_db),
        }
    }
}

/// Renders a loaded scene to interleaved-free stereo (left, right). `block` is the processing
/// block size; `progress` is called with the fraction done.
pub fn render(loaded: &LoadedScene, block: usize, mut progress: impl FnMut(f64)) -> (Vec<f32>, Vec<f32>) {
    let scene = &loaded.scene;
    let sr = scene.sample_rate as f64;
    let total = (scene.duration_s * sr).round() as usize;
    let block = block.clamp(1, 8192);
    let mut engine = Engine::new(&loaded.preset, crate::engine::DEFAULT_MAX_VOICES, scene.seed);
    engine.prepare(sr, block);
    let settings = scene.settings();
    let mut timed: Vec<(usize, Event)> = scene
        .events
        .iter()
        .map(|e| {
            let at = (e.time_s() * sr).round() as usize;
            let ev = match *e {
                SceneEvent::Impact {
                    velocity_m_per_s,
                    pitch,
                    ..
                } => Event::Impact {
                    offset: 0,
                    velocity_m_per_s,
                    pitch_factor: pitch,
                    key: -1,
                },
                SceneEvent::NewObject { seed, .. } => Event::NewObject { offset: 0, seed },
            };
            (at, ev)
        })
        .collect();
    timed.sort_by_key(|(t, _)| *t);
    let mut left = vec![0.0f32; total];
    let mut right = vec![0.0f32; total];
    let mut events = Vec::with_capacity(16);
    let mut next = 0;
    let mut pos = 0;
    while pos < total {
        let end = (pos + block).min(total);
        events.clear();
        while next < timed.len() && timed[next].0 < end {
            let mut e = timed[next].1;
            let off = (timed[next].0 - pos) as u32;
            match &mut e {
                Event::Impact { offset, .. }
                | Event::Choke { offset, .. }
                | Event::NewObject { offset, .. } => *offset = off,
            }
            events.push(e);
            next += 1;
        }
        engine.process(&settings, &events, &mut left[pos..end], &mut right[pos..end]);
        pos = end;
        progress(pos as f64 / total as f64);
    }
    (left, right)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demo_scene_parses() {
        let s = Scene::parse(DEMO_SCENE, None).unwrap();
        assert!(s.scene.events.len() > 3);
    }

    #[test]
    fn bad_scenes_explain_themselves() {
        let e = Scene::parse(r#"{"duration_s": -1, "material": "wood"}"#, None).unwrap_err();
        assert!(e.to_string().contains("duration_s"), "{e}");
        let e = Scene::parse(r#"{"duration_s": 1, "material": "unobtainium"}"#, None).unwrap_err();
        assert!(e.to_string().contains("unknown material 'unobtainium'"), "{e}");
        let e = Scene::parse("{not json", None).unwrap_err();
        assert!(e.to_string().contains("invalid scene JSON"), "{e}");
    }

    #[test]
    fn render_is_deterministic_and_block_size_independent() {
        let s = Scene::parse(DEMO_SCENE, None).unwrap();
        let mut short = s.clone();
        short.scene.duration_s = 1.5;
        let (a, _) = render(&short, 512, |_| {});
        let (b, _) = render(&short, 512, |_| {});
        let (c, _) = render(&short, 37, |_| {});
        assert_eq!(a, b);
        let peak = a.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(peak > 1e-3, "render is silent");
        let max_diff = a.iter().zip(&c).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
        assert!(max_diff <= 1e-5 * peak, "block size changed output by {max_diff}");
    }
}
