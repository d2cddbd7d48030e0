//! Offline scenes: the JSON format `tactus render` reads (documented in the README), parsing
//! with readable errors, and the renderer that turns a scene into audio through the engine.

use crate::engine::gesture::{BounceParams, BreakParams, RattleParams};
use crate::engine::settings::{FieldSpec, SettingError, SettingsGroup};
use crate::engine::sustained::MotionKind;
use crate::engine::{materials, Ablation, RollParams, ScrapeParams, Settings, MAX_CONTACT_SPEED};
use crate::preset::Preset;
use anyhow::Context;
use serde::{Deserialize, Deserializer};
use std::collections::BTreeMap;
use std::path::Path;

mod gesture;
mod render;
pub use gesture::GestureEvent;
pub use render::{render, render_objects};

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

/// A scene's `settings` object: the engine's impact and output settings written flat
/// (`{"size": 2, "gain_db": -6}`), every field optional. This is the one place the flat scene
/// form maps onto the nested [`Settings`]: the names, types and ranges are [`Settings`]' own
/// ([`crate::engine::ImpactSettings`], [`crate::engine::OutputSettings`]), so a field added there
/// is accepted here with no change.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SceneSettings {
    /// The given values over the defaults.
    values: Settings,
    /// The names of the fields the scene gave, which override the next level's.
    given: Vec<&'static str>,
}

impl SceneSettings {
    /// The fields a scene's `settings` accepts.
    fn fields() -> impl Iterator<Item = &'static FieldSpec> {
        crate::engine::ImpactSettings::FIELDS
            .iter()
            .chain(crate::engine::OutputSettings::FIELDS)
    }

    /// Writes the given fields over `to`.
    fn apply(&self, to: &mut Settings) {
        for name in &self.given {
            let _ = to.impact.copy_field(&self.values.impact, name)
                || to.output.copy_field(&self.values.output, name);
        }
    }

    /// The first given field outside its range, named `{at}.{field}`.
    fn validate(&self, at: &str) -> Result<(), SettingError> {
        self.values.impact.validate(at)?;
        self.values.output.validate(at)
    }
}

impl<'de> Deserialize<'de> for SceneSettings {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let map = serde_json::Map::<String, serde_json::Value>::deserialize(d)?;
        let mut out = SceneSettings::default();
        for (key, value) in &map {
            let Some(spec) = Self::fields().find(|f| f.name == key) else {
                let names = Self::fields().map(|f| f.name);
                return Err(D::Error::custom(unknown_key(key, names)));
            };
            let set = out.values.impact.set_json(key, value);
            let set = set.or_else(|| out.values.output.set_json(key, value));
            if let Some(Err(e)) = set {
                return Err(D::Error::custom(format!("settings.{key}: {e}")));
            }
            out.given.push(spec.name);
        }
        Ok(out)
    }
}

/// The error for an unknown key, worded as serde's for a struct with `deny_unknown_fields`.
fn unknown_key<'a>(key: &str, valid: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<String> = valid.map(|n| format!("`{n}`")).collect();
    format!("unknown field `{key}`, expected one of {}", names.join(", "))
}

/// One timed event.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SceneEvent {
    /// An impact at `time_s`.
    Impact {
        /// Object struck (a key of the scene's `objects`; omitted in one-object scenes).
        #[serde(default)]
        object: Option<String>,
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
        /// Object redrawn (a key of the scene's `objects`; omitted in one-object scenes).
        #[serde(default)]
        object: Option<String>,
        /// Time in s.
        time_s: f64,
        /// Seed of the new object.
        seed: u64,
    },
    /// Scraping from `time_s` for `duration_s`: the contact's settings are [`ScrapeParams`]'.
    Scrape(ContactEvent<ScrapeParams>),
    /// An eccentric ball rolling from `time_s` for `duration_s`: the contact's settings are
    /// [`RollParams`]'.
    Roll(ContactEvent<RollParams>),
    /// An object dropped onto a rigid floor, bouncing (docs/model.md §11).
    Bounce(GestureEvent<BounceParams>),
    /// An object struck hard enough to break into fragments (docs/model.md §11).
    Break(GestureEvent<BreakParams>),
    /// Small objects shaken in the object (docs/model.md §11).
    Rattle(GestureEvent<RattleParams>),
}

fn one() -> f64 {
    1.0
}

/// A scrape or roll event: its own keys (object, span and speed input) and, under every other
/// key, a field of its contact's settings group `P` by that field's name. The keys are read
/// through `P`'s [`SettingsGroup`] table, so a field added to [`ScrapeParams`] or
/// [`RollParams`] is a key of the event with no change here; unknown keys are rejected with the
/// list of valid ones.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactEvent<P> {
    /// Object the contact acts on (a key of the scene's `objects`; omitted in one-object
    /// scenes).
    pub object: Option<String>,
    /// Start, s.
    pub time_s: f64,
    /// Length, s.
    pub duration_s: f64,
    /// Constant speed, m/s (peak speed of a preset motion). Exclusive with `speed_curve`.
    pub speed_m_per_s: Option<f64>,
    /// Breakpoints `[t_s, v_m_per_s]` relative to the event start, linearly interpolated
    /// (held before the first / after the last). Manual motion and rolls only.
    pub speed_curve: Option<Vec<[f64; 2]>>,
    /// The contact's settings: `P`'s defaults with the event's keys over them. Its
    /// `speed_m_per_s` is unused: the event's own `speed_m_per_s` (or `speed_curve`) is the speed.
    pub params: P,
}

impl<P> ContactEvent<P> {
    /// This event as a contact with the settings `params`.
    fn with(&self, params: ContactParams) -> SceneContact<'_> {
        SceneContact {
            time_s: self.time_s,
            duration_s: self.duration_s,
            speed_m_per_s: self.speed_m_per_s,
            speed_curve: self.speed_curve.as_deref(),
            params,
        }
    }

    /// The event's own keys, in the order the error for an unknown key lists them (before the
    /// settings group's). `speed_m_per_s` is also a settings field; the event reads it itself
    /// because it may be absent (a curve gives the speed instead).
    const OWN_KEYS: [&'static str; 5] = ["object", "time_s", "duration_s", "speed_m_per_s", "speed_curve"];
}

impl<'de, P: SettingsGroup> Deserialize<'de> for ContactEvent<P> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(ContactEventVisitor(std::marker::PhantomData))
    }
}

struct ContactEventVisitor<P>(std::marker::PhantomData<P>);

impl<'de, P: SettingsGroup> serde::de::Visitor<'de> for ContactEventVisitor<P> {
    type Value = ContactEvent<P>;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a scrape or roll event")
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        use serde::de::Error;
        let keys = || {
            let table = P::FIELDS.iter().map(|f| f.name);
            let own = ContactEvent::<P>::OWN_KEYS;
            own.into_iter().chain(table.filter(move |n| !own.contains(n)))
        };
        let mut given: Vec<&'static str> = Vec::new();
        let (mut object, mut time_s, mut duration_s) = (None, None, None);
        let (mut speed_m_per_s, mut speed_curve) = (None, None);
        let mut params = P::default();
        while let Some(key) = map.next_key::<String>()? {
            let Some(name) = keys().find(|n| *n == key) else {
                return Err(A::Error::custom(unknown_key(&key, keys())));
            };
            if given.contains(&name) {
                return Err(A::Error::duplicate_field(name));
            }
            given.push(name);
            match name {
                "object" => object = map.next_value()?,
                "time_s" => time_s = Some(map.next_value()?),
                "duration_s" => duration_s = Some(map.next_value()?),
                "speed_m_per_s" => speed_m_per_s = map.next_value()?,
                "speed_curve" => speed_curve = map.next_value()?,
                _ => {
                    let value: serde_json::Value = map.next_value()?;
                    if let Some(Err(e)) = params.set_json(name, &value) {
                        return Err(A::Error::custom(e));
                    }
                }
            }
        }
        Ok(ContactEvent {
            object,
            time_s: time_s.ok_or_else(|| A::Error::missing_field("time_s"))?,
            duration_s: duration_s.ok_or_else(|| A::Error::missing_field("duration_s"))?,
            speed_m_per_s,
            speed_curve,
            params,
        })
    }
}

/// A scrape or roll event in the engine's terms: its span, its speed input and its contact's
/// settings (whose `speed_m_per_s` is the constant speed, 0 with a curve).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SceneContact<'a> {
    /// Start, s.
    pub(crate) time_s: f64,
    /// Length, s.
    pub(crate) duration_s: f64,
    /// The constant speed, if given.
    pub(crate) speed_m_per_s: Option<f64>,
    /// The speed curve, if given.
    pub(crate) speed_curve: Option<&'a [[f64; 2]]>,
    /// The contact's settings.
    pub(crate) params: ContactParams,
}

/// The settings of a scrape or of a roll.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ContactParams {
    /// A scrape event's.
    Scrape(ScrapeParams),
    /// A roll event's.
    Roll(RollParams),
}

impl SceneEvent {
    fn time_s(&self) -> f64 {
        match self {
            SceneEvent::Impact { time_s, .. }
            | SceneEvent::NewObject { time_s, .. }
            | SceneEvent::Scrape(ContactEvent { time_s, .. })
            | SceneEvent::Roll(ContactEvent { time_s, .. })
            | SceneEvent::Bounce(GestureEvent { time_s, .. })
            | SceneEvent::Break(GestureEvent { time_s, .. })
            | SceneEvent::Rattle(GestureEvent { time_s, .. }) => *time_s,
        }
    }

    /// A scrape or roll event as a contact; `None` for other events.
    pub(crate) fn contact(&self) -> Option<SceneContact<'_>> {
        Some(match self {
            SceneEvent::Scrape(c) => c.with(ContactParams::Scrape(ScrapeParams {
                speed_m_per_s: c.speed_m_per_s.unwrap_or(0.0),
                ..c.params
            })),
            SceneEvent::Roll(c) => c.with(ContactParams::Roll(RollParams {
                speed_m_per_s: c.speed_m_per_s.unwrap_or(0.0),
                ..c.params
            })),
            _ => return None,
        })
    }

    /// The object this event names, if any.
    pub fn object(&self) -> Option<&str> {
        match self {
            SceneEvent::Impact { object, .. }
            | SceneEvent::NewObject { object, .. }
            | SceneEvent::Scrape(ContactEvent { object, .. })
            | SceneEvent::Roll(ContactEvent { object, .. })
            | SceneEvent::Bounce(GestureEvent { object, .. })
            | SceneEvent::Break(GestureEvent { object, .. })
            | SceneEvent::Rattle(GestureEvent { object, .. }) => object.as_deref(),
        }
    }
}

/// One sounding object of a multi-object scene.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SceneObject {
    /// Material: a built-in name or `{"preset_file": ...}`.
    pub material: MaterialRef,
    /// Seed of the object's first draw and of its per-hit variation (default: the scene's seed).
    #[serde(default)]
    pub seed: Option<u64>,
    /// Settings of this object; a field left out takes the scene's `settings` value.
    #[serde(default)]
    pub settings: SceneSettings,
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
    /// Material of a one-object scene (exclusive with `objects`).
    #[serde(default)]
    pub material: Option<MaterialRef>,
    /// Named objects of a multi-object scene (exclusive with `material`); they render in name
    /// order, each with its own engine, and mix to the output.
    #[serde(default)]
    pub objects: BTreeMap<String, SceneObject>,
    /// Engine settings (in a multi-object scene: the defaults of every object).
    #[serde(default)]
    pub settings: SceneSettings,
    /// Timed events.
    #[serde(default)]
    pub events: Vec<SceneEvent>,
    /// Ablation switches of the scraping / rolling model.
    #[serde(default)]
    pub ablation: Ablation,
}

fn default_sr() -> u32 {
    48_000
}

fn default_seed() -> u64 {
    1
}

/// A scene made ready to render: parsed, validated, materials resolved.
#[derive(Debug, Clone)]
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// The resolved material of a one-object scene (of a multi-object scene: its first object's).
    pub preset: Preset,
    /// The objects with their resolved materials, in render order; a one-object scene has one,
    /// named "" (its events name no object).
    pub objects: Vec<LoadedObject>,
}

/// One object of a loaded scene.
#[derive(Debug, Clone)]
pub struct LoadedObject {
    /// Key in the scene's `objects` ("" in a one-object scene).
    pub name: String,
    /// Resolved material.
    pub preset: Preset,
}

/// Looks up a built-in material by name, case-insensitively.
pub fn builtin_material(name: &str) -> Option<Preset> {
    materials::shipped_presets()
        .into_iter()
        .find(|p| p.name.eq_ignore_ascii_case(name) || p.material_class.eq_ignore_ascii_case(name))
}

impl Scene {
    /// Parses and validates scene JSON. `base` resolves relative preset paths.
    pub fn parse(text: &str, base: Option<&Path>) -> anyhow::Result<LoadedScene> {
        let scene: Scene =
            serde_json::from_str(text).map_err(|e| anyhow::anyhow!("invalid scene JSON: {e}"))?;
        scene.validate(base)
    }

    /// [`Scene::parse`] from an already parsed JSON value (batch variations edit scenes as
    /// values).
    pub fn from_value(value: serde_json::Value, base: Option<&Path>) -> anyhow::Result<LoadedScene> {
        let scene: Scene =
            serde_json::from_value(value).map_err(|e| anyhow::anyhow!("invalid scene JSON: {e}"))?;
        scene.validate(base)
    }

    fn validate(self, base: Option<&Path>) -> anyhow::Result<LoadedScene> {
        self.check_rate_duration_and_settings()?;
        let multi = match (&self.material, self.objects.is_empty()) {
            (Some(_), true) => false,
            (None, false) => true,
            (Some(_), false) => {
                anyhow::bail!("scene: give either `material` (one object) or `objects`, not both")
            }
            (None, true) => anyhow::bail!("scene: missing `material` (or `objects` for several objects)"),
        };
        self.check_events(multi)?;
        self.check_overlaps(multi)?;
        let objects = self.load_objects(base)?;
        let preset = objects[0].preset.clone();
        Ok(LoadedScene {
            scene: self,
            preset,
            objects,
        })
    }

    /// The sample rate, duration, settings and object names, checked.
    fn check_rate_duration_and_settings(&self) -> anyhow::Result<()> {
        let scene = self;
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
        scene
            .settings
            .validate("settings")
            .map_err(|e| anyhow::anyhow!("scene: {e}"))?;
        for (name, o) in &scene.objects {
            // Names become stem file names (`render --stems`).
            let ok = !name.is_empty()
                && !name.starts_with('.')
                && name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
            if !ok {
                anyhow::bail!(
                    "scene: object name '{name}' must be letters, digits, '_', '-' or '.' (not first)"
                );
            }
            o.settings
                .validate(&format!("objects.{name}.settings"))
                .map_err(|e| anyhow::anyhow!("scene: {e}"))?;
        }
        Ok(())
    }

    /// Every event's time, object, impact values, contact and gesture, checked (`multi`: the
    /// scene has `objects`).
    fn check_events(&self, multi: bool) -> anyhow::Result<()> {
        let scene = self;
        for (i, e) in scene.events.iter().enumerate() {
            let t = e.time_s();
            if !t.is_finite() || t < 0.0 {
                anyhow::bail!("scene: events[{i}].time_s must be ≥ 0, got {t}");
            }
            if t >= scene.duration_s {
                anyhow::bail!(
                    "scene: events[{i}].time_s {t} s is not before the end of the scene (duration_s {} s)",
                    scene.duration_s
                );
            }
            match (e.object(), multi) {
                (None, true) => {
                    let names: Vec<&str> = scene.objects.keys().map(String::as_str).collect();
                    anyhow::bail!(
                        "scene: events[{i}] needs an \"object\" (one of: {})",
                        names.join(", ")
                    )
                }
                (Some(o), true) if !scene.objects.contains_key(o) => {
                    let names: Vec<&str> = scene.objects.keys().map(String::as_str).collect();
                    anyhow::bail!(
                        "scene: events[{i}].object '{o}' is not in `objects` (one of: {})",
                        names.join(", ")
                    )
                }
                (Some(o), false) => anyhow::bail!(
                    "scene: events[{i}].object '{o}' names an object, but the scene has no `objects` (it uses `material`)"
                ),
                _ => {}
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
            validate_contact(i, e)?;
            gesture::validate_gesture(i, e)?;
        }
        Ok(())
    }

    /// No object has two scrape (or two roll) contacts at once (`multi`: the scene has
    /// `objects`).
    fn check_overlaps(&self, multi: bool) -> anyhow::Result<()> {
        let scene = self;
        let names: Vec<Option<&str>> = if multi {
            scene.objects.keys().map(|k| Some(k.as_str())).collect()
        } else {
            vec![None]
        };
        for (name, scrape) in names.iter().flat_map(|n| [(n, true), (n, false)]) {
            let mut spans: Vec<(f64, f64)> = scene
                .events
                .iter()
                .filter(|e| e.object() == *name)
                .filter_map(|e| e.contact())
                .filter(|c| matches!(c.params, ContactParams::Scrape(_)) == scrape)
                .map(|c| (c.time_s, c.time_s + c.duration_s))
                .collect();
            if !scrape {
                // A bounce's roll (`roll_after`) is a roll contact like a roll event's.
                spans.extend(scene.handovers(*name).iter().map(|(t, h)| (*t, t + h.duration_s)));
            }
            spans.sort_by(|a, b| a.0.total_cmp(&b.0));
            if spans.windows(2).any(|w| w[1].0 < w[0].1) {
                let kind = if scrape { "scrape" } else { "roll" };
                match name {
                    Some(n) => anyhow::bail!(
                        "scene: {kind} events of object '{n}' overlap (one {kind} contact per object at a time)"
                    ),
                    None => anyhow::bail!("scene: {kind} events overlap (one {kind} contact at a time)"),
                }
            }
        }
        Ok(())
    }

    /// The scene's objects with their presets (built-in names, or files relative to `base`).
    fn load_objects(&self, base: Option<&Path>) -> anyhow::Result<Vec<LoadedObject>> {
        let scene = self;
        let resolve = |m: &MaterialRef| -> anyhow::Result<Preset> {
            Ok(match m {
                MaterialRef::Name(n) => builtin_material(n).ok_or_else(|| {
                    let names: Vec<String> =
                        materials::shipped_presets().into_iter().map(|p| p.name).collect();
                    anyhow::anyhow!("scene: unknown material '{n}' (available: {})", names.join(", "))
                })?,
                MaterialRef::File { preset_file } => {
                    let p = match base {
                        Some(b) => b.join(preset_file),
                        None => preset_file.into(),
                    };
                    Preset::load(&p)?
                }
            })
        };
        Ok(match &scene.material {
            Some(m) => vec![LoadedObject {
                name: String::new(),
                preset: resolve(m)?,
            }],
            None => scene
                .objects
                .iter()
                .map(|(name, o)| {
                    Ok(LoadedObject {
                        name: name.clone(),
                        preset: resolve(&o.material)?,
                    })
                })
                .collect::<anyhow::Result<Vec<_>>>()?,
        })
    }

    /// Reads and parses a scene file.
    pub fn load(path: &Path) -> anyhow::Result<LoadedScene> {
        // Context keeps the I/O error in the chain (the Python module raises OSError for it).
        let text =
            std::fs::read_to_string(path).with_context(|| format!("cannot read scene {}", path.display()))?;
        Scene::parse(&text, path.parent()).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
    }

    /// Engine settings of this scene (of a one-object scene's object).
    pub fn settings(&self) -> Settings {
        self.object_settings(&SceneSettings::default())
    }

    /// Engine settings of an object: its own `settings` over the scene's, over the defaults.
    /// No contact outside its events: the scrape and roll forces are 0 until an event sets them.
    pub(crate) fn object_settings(&self, own: &SceneSettings) -> Settings {
        let mut s = Settings::default();
        s.scrape.pressure_n = 0.0;
        s.roll.pressure_n = 0.0;
        s.ablation = self.ablation;
        self.settings.apply(&mut s);
        own.apply(&mut s);
        s
    }
}

fn validate_contact(i: usize, e: &SceneEvent) -> anyhow::Result<()> {
    let Some(c) = e.contact() else {
        return Ok(());
    };
    let d = c.duration_s;
    if !d.is_finite() || d <= 0.0 || d > MAX_DURATION_S {
        anyhow::bail!("scene: events[{i}].duration_s must be in (0, {MAX_DURATION_S}] s, got {d}");
    }
    let at = format!("events[{i}]");
    let checked = match c.params {
        ContactParams::Scrape(p) => p.validate(&at).map(|()| p.motion == MotionKind::Manual),
        ContactParams::Roll(p) => p.validate(&at).map(|()| true),
    };
    let manual = checked.map_err(|e| anyhow::anyhow!("scene: {e}"))?;
    match (c.speed_m_per_s, c.speed_curve) {
        (Some(_), None) => {}
        (None, Some(curve)) => {
            if !manual {
                anyhow::bail!(
                    "scene: events[{i}].speed_curve needs \"motion\": \"manual\" (preset motions take a constant peak speed_m_per_s)"
                );
            }
            if curve.is_empty() {
                anyhow::bail!(
                    "scene: events[{i}].speed_curve needs at least one [t_s, v_m_per_s] breakpoint"
                );
            }
            for (j, p) in curve.iter().enumerate() {
                if !p[0].is_finite() || p[0] < 0.0 || (j > 0 && p[0] < curve[j - 1][0]) {
                    anyhow::bail!(
                        "scene: events[{i}].speed_curve[{j}]: times must be ≥ 0 and non-decreasing, got {}",
                        p[0]
                    );
                }
                if !p[1].is_finite() || p[1].abs() > MAX_CONTACT_SPEED {
                    anyhow::bail!(
                        "scene: events[{i}].speed_curve[{j}]: speed must be within ±{MAX_CONTACT_SPEED} m/s, got {}",
                        p[1]
                    );
                }
            }
        }
        (Some(_), Some(_)) => {
            anyhow::bail!("scene: events[{i}] has both speed_m_per_s and speed_curve; give one")
        }
        (None, None) => anyhow::bail!("scene: events[{i}] needs speed_m_per_s or speed_curve"),
    }
    Ok(())
}

#[cfg(test)]
mod tests;
