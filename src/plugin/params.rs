//! Plugin parameters. The ids are stable forever (saved projects and automation refer to them);
//! display names equal the words of the id because hosts such as pedalboard address parameters by
//! display name. Ranges are functions so the editor can reuse them.

use super::user_preset::UserPresetSlot;
use crate::engine::force::ContactModel;
use crate::engine::gesture::{BounceParams, BreakParams, RattleParams, MAX_FRAGMENTS};
use crate::engine::materials::{BUILTIN_SPECS, FAMILY_PRESET_NAMES, MEASURED_PRESET_NAMES};
use crate::engine::stereo::DEFAULT_WIDTH;
use crate::engine::sustained::{MotionKind, SurfaceKind};
use crate::engine::Settings;
use nice_plug::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64};
use std::sync::Arc;

/// Version of the persisted state written by this build (see `docs/plugin.md`, "State").
pub const STATE_VERSION: u32 = 1;

/// Largest value of the `seed` parameter; [`next_seed`] stays in `0..=MAX_SEED`.
pub const MAX_SEED: i32 = 999_999;

/// The seed drawn by "New Object": a deterministic function of the previous seed (SplitMix64
/// finaliser, reduced to the `seed` parameter's range so the result can be typed back in).
pub fn next_seed(seed: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    let next = z % (MAX_SEED as u64 + 1);
    if next == seed {
        (seed + 1) % (MAX_SEED as u64 + 1)
    } else {
        next
    }
}

/// What the MIDI key does.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoteMode {
    /// The key shifts all frequencies (equal-tempered, relative to middle C).
    #[id = "pitch"]
    #[name = "Pitch"]
    Pitch,
    /// Every key plays the same object at its own pitch.
    #[id = "fixed"]
    #[name = "Fixed"]
    Fixed,
}

/// What a note plays (docs/plugin.md, "Gestures"; docs/model.md §11).
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum GestureChoice {
    /// One impact.
    #[id = "strike"]
    #[name = "Strike"]
    Strike,
    /// The object dropped from `height`, bouncing with `restitution`.
    #[id = "bounce"]
    #[name = "Bounce"]
    Bounce,
    /// A strike that breaks the object into `fragments` pieces.
    #[id = "break"]
    #[name = "Break"]
    Break,
    /// Small objects shaken in the object while the note is held.
    #[id = "rattle"]
    #[name = "Rattle"]
    Rattle,
}

/// Contact model choices, in parameter order.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ContactModelChoice {
    /// Linear spring half-sine.
    #[id = "spring"]
    #[name = "Spring"]
    Spring,
    /// Raised cosine.
    #[id = "raised_cosine"]
    #[name = "Raised Cosine"]
    RaisedCosine,
    /// Hunt–Crossley non-linear contact.
    #[id = "hunt_crossley"]
    #[name = "Hunt-Crossley"]
    HuntCrossley,
}

impl From<ContactModelChoice> for ContactModel {
    fn from(c: ContactModelChoice) -> Self {
        match c {
            ContactModelChoice::Spring => ContactModel::Spring,
            ContactModelChoice::RaisedCosine => ContactModel::RaisedCosine,
            ContactModelChoice::HuntCrossley => ContactModel::HuntCrossley,
        }
    }
}

/// Scrape motion choices, in parameter order.
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScrapeMotionChoice {
    /// Speed straight from the Scrape Speed parameter.
    #[id = "manual"]
    #[name = "Manual"]
    Manual,
    /// Hand-held back-and-forth (simple harmonic motion).
    #[id = "back_and_forth"]
    #[name = "Back and Forth"]
    BackAndForth,
    /// Circular motion.
    #[id = "circular"]
    #[name = "Circular"]
    Circular,
    /// Four straight strokes in a line.
    #[id = "strokes"]
    #[name = "Strokes"]
    Strokes,
    /// Scribble.
    #[id = "scribble"]
    #[name = "Scribble"]
    Scribble,
    /// One long stroke.
    #[id = "long_stroke"]
    #[name = "Long Stroke"]
    LongStroke,
}

impl From<ScrapeMotionChoice> for MotionKind {
    fn from(c: ScrapeMotionChoice) -> Self {
        match c {
            ScrapeMotionChoice::Manual => MotionKind::Manual,
            ScrapeMotionChoice::BackAndForth => MotionKind::BackAndForth,
            ScrapeMotionChoice::Circular => MotionKind::Circular,
            ScrapeMotionChoice::Strokes => MotionKind::Strokes,
            ScrapeMotionChoice::Scribble => MotionKind::Scribble,
            ScrapeMotionChoice::LongStroke => MotionKind::LongStroke,
        }
    }
}

/// Surface choices, in parameter order: [`SurfaceKind::ALL`]'s (a test checks it).
#[derive(Enum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SurfaceChoice {
    /// The synthetic surface, its RMS height set by Roughness.
    #[id = "synthetic"]
    #[name = "Synthetic"]
    Synthetic,
    /// Measured: acrylic.
    #[id = "acrylic"]
    #[name = "Acrylic"]
    Acrylic,
    /// Measured: bass wood.
    #[id = "bass_wood"]
    #[name = "Bass Wood"]
    BassWood,
    /// Measured: ceramic.
    #[id = "ceramic"]
    #[name = "Ceramic"]
    Ceramic,
    /// Measured: plywood.
    #[id = "plywood"]
    #[name = "Plywood"]
    Plywood,
    /// Measured: polycarbonate.
    #[id = "polycarbonate"]
    #[name = "Polycarbonate"]
    Polycarbonate,
    /// Measured: polyethylene.
    #[id = "polyethylene"]
    #[name = "Polyethylene"]
    Polyethylene,
    /// Measured: poplar wood.
    #[id = "poplar_wood"]
    #[name = "Poplar Wood"]
    PoplarWood,
    /// Measured: PVC.
    #[id = "pvc"]
    #[name = "PVC"]
    Pvc,
    /// Measured: rough wood.
    #[id = "rough_wood"]
    #[name = "Rough Wood"]
    RoughWood,
    /// Measured: sanded acrylic.
    #[id = "sanded_acrylic"]
    #[name = "Sanded Acrylic"]
    SandedAcrylic,
    /// Measured: sandpaper.
    #[id = "sandpaper"]
    #[name = "Sandpaper"]
    Sandpaper,
    /// Measured: vinyl.
    #[id = "vinyl"]
    #[name = "Vinyl"]
    Vinyl,
}

impl From<SurfaceChoice> for SurfaceKind {
    fn from(c: SurfaceChoice) -> Self {
        SurfaceKind::ALL[c as usize]
    }
}

/// Number of entries of the `material` parameter: the built-ins, one user-preset slot, the
/// fitted family presets, then the measured materials (each appended after the last, so saved
/// indices keep their material).
pub const MATERIAL_COUNT: usize =
    BUILTIN_SPECS.len() + 1 + FAMILY_PRESET_NAMES.len() + MEASURED_PRESET_NAMES.len();

/// Display name of material index `i`.
pub fn material_name(i: i32) -> String {
    let i = i.max(0) as usize;
    let n = BUILTIN_SPECS.len();
    match i.cmp(&n) {
        std::cmp::Ordering::Less => BUILTIN_SPECS[i].name.to_string(),
        std::cmp::Ordering::Equal => "User Preset".to_string(),
        std::cmp::Ordering::Greater => FAMILY_PRESET_NAMES
            .iter()
            .chain(&MEASURED_PRESET_NAMES)
            .nth(i - n - 1)
            .map_or_else(|| "User Preset".to_string(), |s| (*s).to_string()),
    }
}

fn parse_material(s: &str) -> Option<i32> {
    let s = s.trim();
    if let Ok(i) = s.parse::<i32>() {
        return Some(i);
    }
    (0..MATERIAL_COUNT as i32).find(|&i| material_name(i).eq_ignore_ascii_case(s))
}

/// Parses the leading number of a display string ("1.50 m/s" → 1.5), for round-tripping.
fn s2v_number() -> Arc<dyn Fn(&str) -> Option<f32> + Send + Sync> {
    Arc::new(|s: &str| {
        let s = s.trim();
        let end = s
            .char_indices()
            .find(|(_, c)| !(c.is_ascii_digit() || matches!(c, '.' | '-' | '+' | 'e' | 'E')))
            .map_or(s.len(), |(i, _)| i);
        s[..end].parse::<f32>().ok().filter(|v| v.is_finite())
    })
}

fn float(name: &str, default: f32, range: FloatRange, unit: &'static str, digits: usize) -> FloatParam {
    FloatParam::new(name, default, range)
        .with_unit(unit)
        .with_value_to_string(formatters::v2s_f32_rounded(digits))
        .with_string_to_value(s2v_number())
}

/// Range of `size` (object scale).
pub fn size_range() -> FloatRange {
    FloatRange::Skewed {
        min: 0.25,
        max: 4.0,
        factor: FloatRange::skew_factor(-1.0),
    }
}
/// Range of `mass` in kg (1 g – 5 kg, logarithmic feel).
pub fn mass_range() -> FloatRange {
    FloatRange::Skewed {
        min: 0.001,
        max: 5.0,
        factor: FloatRange::skew_factor(-2.5),
    }
}
/// Range of `velocity` in m/s.
pub fn velocity_range() -> FloatRange {
    FloatRange::Skewed {
        min: 0.01,
        max: 10.0,
        factor: FloatRange::skew_factor(-2.0),
    }
}
/// Range of `height` in m (a bounce's drop at full note velocity).
pub fn height_range() -> FloatRange {
    FloatRange::Skewed {
        min: 0.01,
        max: 10.0,
        factor: FloatRange::skew_factor(-2.0),
    }
}
/// Range of the break's `spread` in s: the engine's 0–10 s holds far longer windows than a
/// break's, so the knob stops at 2 s, finer at the short end where breaks lie.
pub fn spread_range() -> FloatRange {
    FloatRange::Skewed {
        min: 0.0,
        max: 2.0,
        factor: FloatRange::skew_factor(-1.0),
    }
}
/// Range of multiplier parameters (`damping`, `hardness`).
pub fn multiplier_range() -> FloatRange {
    FloatRange::Skewed {
        min: 0.05,
        max: 20.0,
        factor: FloatRange::skew_factor(-2.0),
    }
}

/// All parameters of the plugin.
#[derive(Params)]
pub struct TactusParams {
    /// Material: built-in presets, then the user preset slot.
    #[id = "material"]
    pub material: IntParam,
    /// Object scale, 1 = the preset's reference object; frequencies scale as 1/size.
    #[id = "size"]
    pub size: FloatParam,
    /// Decay multiplier: > 1 shortens decays (softer-sounding), < 1 lengthens them (harder).
    #[id = "damping"]
    pub damping: FloatParam,
    /// Striker mass in kg.
    #[id = "mass"]
    pub mass: FloatParam,
    /// Impact speed in m/s at full MIDI velocity.
    #[id = "velocity"]
    pub velocity: FloatParam,
    /// Contact stiffness multiplier on the material's stiffness.
    #[id = "hardness"]
    pub hardness: FloatParam,
    /// Impact contact model.
    #[id = "contact_model"]
    pub contact_model: EnumParam<ContactModelChoice>,
    /// Scraper speed in m/s.
    #[id = "scrape_speed"]
    pub scrape_speed: FloatParam,
    /// Scrape motion preset.
    #[id = "scrape_motion"]
    pub scrape_motion: EnumParam<ScrapeMotionChoice>,
    /// Mean normal force of the scraper in N.
    #[id = "scrape_pressure"]
    pub scrape_pressure: FloatParam,
    /// Surface roughness, 0..1.
    #[id = "roughness"]
    pub roughness: FloatParam,
    /// Rolling speed in m/s.
    #[id = "roll_speed"]
    pub roll_speed: FloatParam,
    /// Ball radius R in m.
    #[id = "roll_radius"]
    pub roll_radius: FloatParam,
    /// Offset of the ball's centre of mass, r/R.
    #[id = "roll_eccentricity"]
    pub roll_eccentricity: FloatParam,
    /// Variation of mode onset power on re-hits of one object (20 % = Traer et al.); an object's
    /// first hit sounds its drawn levels.
    #[id = "variation"]
    pub variation: FloatParam,
    /// Culling threshold: modes this many dB below the strongest are not computed.
    #[id = "quality"]
    pub quality: FloatParam,
    /// Output gain in dB.
    #[id = "gain"]
    pub gain: FloatParam,
    /// Trigger: going from off to on draws a new object whose seed is [`next_seed`] of the current
    /// one. Set it back to off to arm it again.
    #[id = "new_object"]
    pub new_object: BoolParam,
    /// Object seed. Changing it draws the object with exactly this seed.
    #[id = "seed"]
    pub seed: IntParam,
    /// Pitch: keys transpose; Fixed: all keys sound the same.
    #[id = "note_mode"]
    pub note_mode: EnumParam<NoteMode>,
    /// The rolling ball's weight (its mean normal force) in N.
    #[id = "roll_pressure"]
    pub roll_pressure: FloatParam,
    /// Stereo width (docs/model.md "Stereo pickups"): 0 = mono, 1 = two independent pickups.
    /// Starts at [`DEFAULT_WIDTH`], not the engine's 0: see there.
    #[id = "width"]
    pub width: FloatParam,
    /// What a note plays: one strike or a gesture.
    #[id = "gesture"]
    pub gesture: EnumParam<GestureChoice>,
    /// Bounce: drop height in m at full note velocity.
    #[id = "height"]
    pub height: FloatParam,
    /// Bounce and Break: coefficient of restitution.
    #[id = "restitution"]
    pub restitution: FloatParam,
    /// Break: number of fragments; Rattle: number of rattling objects (at most 16).
    #[id = "fragments"]
    pub fragments: IntParam,
    /// Rattle: mean impacts per second.
    #[id = "rattle_rate"]
    pub rattle_rate: FloatParam,
    /// Break: window over which the fragments first land, s after the burst (a scene break's
    /// `spread_s`).
    #[id = "spread"]
    pub spread: FloatParam,
    /// The surface under the scraper and the ball: synthetic or one of the measured ones.
    #[id = "surface"]
    pub surface: EnumParam<SurfaceChoice>,
    /// Output limiter ([`crate::engine::limiter`]): on, no output sample exceeds −0.3 dBFS and
    /// material under it passes bit-identical; off, the float output is unlimited. On in a new
    /// instance; a project saved before the parameter loads with it off ([`super::migrate_state`]).
    #[id = "limiter"]
    pub limiter: BoolParam,

    /// Seed of the current object (the truth; `seed` is where the chain of "New Object" draws
    /// started).
    #[persist = "object_seed"]
    pub object_seed: AtomicU64,
    /// Value of `seed` when `object_seed` was last set from it, so a changed `seed` is noticed
    /// without overriding a restored `object_seed`.
    #[persist = "seed_base"]
    pub seed_base: AtomicU64,
    /// Last seen value of `new_object`, for edge detection that survives state loads.
    #[persist = "new_object_latch"]
    pub new_object_latch: AtomicBool,
    /// The user preset's JSON.
    #[persist = "user_preset"]
    pub user_preset: UserPresetSlot,
    /// Version of the saved state; see [`STATE_VERSION`].
    #[persist = "state_version"]
    pub state_version: AtomicU32,
}

impl Default for TactusParams {
    /// Every parameter that sets an engine setting starts at the engine's default
    /// ([`Settings::default`]), so a new instance sounds as a scene that gives no settings,
    /// except `width` ([`DEFAULT_WIDTH`]: a new instance is stereo, old scenes stay mono). The
    /// knob ranges are a useful part of the engine's ranges (the test
    /// `knobs_lie_in_the_engines_ranges_and_start_at_its_defaults` checks both).
    fn default() -> Self {
        let d = Settings::default();
        let (g_bounce, g_break, g_rattle) = (
            BounceParams::default(),
            BreakParams::default(),
            RattleParams::default(),
        );
        let f = |v: f64| v as f32;
        Self {
            material: IntParam::new(
                "Material",
                1,
                IntRange::Linear {
                    min: 0,
                    max: MATERIAL_COUNT as i32 - 1,
                },
            )
            .with_value_to_string(Arc::new(material_name))
            .with_string_to_value(Arc::new(parse_material)),
            size: float("Size", f(d.impact.size), size_range(), "", 2),
            damping: float("Damping", f(d.impact.damping), multiplier_range(), "", 2),
            mass: float("Mass", f(d.impact.mass_kg), mass_range(), " kg", 3),
            velocity: float("Velocity", 1.0, velocity_range(), " m/s", 2),
            hardness: float("Hardness", f(d.impact.hardness), multiplier_range(), "", 2),
            contact_model: EnumParam::new("Contact Model", ContactModelChoice::HuntCrossley),
            scrape_speed: float(
                "Scrape Speed",
                f(d.scrape.speed_m_per_s),
                FloatRange::Linear { min: 0.0, max: 2.0 },
                " m/s",
                3,
            )
            .with_smoother(SmoothingStyle::Linear(20.0)),
            scrape_motion: EnumParam::new("Scrape Motion", ScrapeMotionChoice::Manual),
            scrape_pressure: float(
                "Scrape Pressure",
                f(d.scrape.pressure_n),
                FloatRange::Skewed {
                    min: 0.0,
                    max: 100.0,
                    factor: FloatRange::skew_factor(-1.5),
                },
                " N",
                2,
            )
            .with_smoother(SmoothingStyle::Linear(20.0)),
            roughness: float(
                "Roughness",
                f(d.scrape.roughness),
                FloatRange::Linear { min: 0.0, max: 1.0 },
                "",
                2,
            )
            .with_smoother(SmoothingStyle::Linear(20.0)),
            roll_speed: float(
                "Roll Speed",
                f(d.roll.speed_m_per_s),
                FloatRange::Linear { min: 0.0, max: 5.0 },
                " m/s",
                3,
            )
            .with_smoother(SmoothingStyle::Linear(20.0)),
            roll_radius: float(
                "Roll Radius",
                f(d.roll.radius_m),
                FloatRange::Skewed {
                    min: 0.001,
                    max: 1.0,
                    factor: FloatRange::skew_factor(-2.5),
                },
                " m",
                4,
            ),
            roll_eccentricity: float(
                "Roll Eccentricity",
                f(d.roll.eccentricity),
                FloatRange::Linear { min: 0.0, max: 0.5 },
                "",
                3,
            ),
            variation: float(
                "Variation",
                f(d.impact.variation),
                FloatRange::Linear { min: 0.0, max: 1.0 },
                "",
                2,
            ),
            quality: float(
                "Quality",
                f(d.output.quality_db),
                FloatRange::Linear {
                    min: 20.0,
                    max: 120.0,
                },
                " dB",
                1,
            ),
            gain: float(
                "Gain",
                f(d.output.gain_db),
                FloatRange::Linear {
                    min: -60.0,
                    max: 12.0,
                },
                " dB",
                1,
            )
            .with_smoother(SmoothingStyle::Linear(20.0)),
            new_object: BoolParam::new("New Object", false),
            seed: IntParam::new(
                "Seed",
                super::DEFAULT_SEED as i32,
                IntRange::Linear {
                    min: 0,
                    max: MAX_SEED,
                },
            ),
            note_mode: EnumParam::new("Note Mode", NoteMode::Pitch),
            roll_pressure: float(
                "Roll Pressure",
                f(d.roll.pressure_n),
                FloatRange::Skewed {
                    min: 0.0,
                    max: 100.0,
                    factor: FloatRange::skew_factor(-1.5),
                },
                " N",
                2,
            )
            .with_smoother(SmoothingStyle::Linear(20.0)),
            // No smoother: the engine ramps every change of width ([`crate::engine::stereo::WIDTH_RAMP_S`]).
            width: float(
                "Width",
                DEFAULT_WIDTH as f32,
                FloatRange::Linear { min: 0.0, max: 1.0 },
                "",
                2,
            ),
            gesture: EnumParam::new("Gesture", GestureChoice::Strike),
            height: float("Height", f(g_bounce.height_m), height_range(), " m", 3),
            restitution: float(
                "Restitution",
                f(g_bounce.restitution),
                FloatRange::Linear { min: 0.0, max: 0.98 },
                "",
                2,
            ),
            fragments: IntParam::new(
                "Fragments",
                g_break.fragments as i32,
                IntRange::Linear {
                    min: 1,
                    max: MAX_FRAGMENTS as i32,
                },
            ),
            rattle_rate: float(
                "Rattle Rate",
                f(g_rattle.rate_hz),
                FloatRange::Skewed {
                    min: 1.0,
                    max: 100.0,
                    factor: FloatRange::skew_factor(-1.0),
                },
                " Hz",
                1,
            ),
            spread: float("Spread", f(g_break.spread_s), spread_range(), " s", 3),
            surface: EnumParam::new("Surface", SurfaceChoice::Synthetic),
            limiter: BoolParam::new("Limiter", true),
            object_seed: AtomicU64::new(super::DEFAULT_SEED),
            seed_base: AtomicU64::new(super::DEFAULT_SEED),
            new_object_latch: AtomicBool::new(false),
            user_preset: UserPresetSlot::default(),
            state_version: AtomicU32::new(STATE_VERSION),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::settings::{Range, SettingsGroup};
    use crate::engine::{ImpactSettings, OutputSettings, RollParams, ScrapeParams};

    #[test]
    fn float_formatters_round_trip() {
        let p = TactusParams::default();
        for (_, ptr, _) in p.param_map() {
            for n in [0.0f32, 0.13, 0.5, 0.77, 1.0] {
                let text = unsafe { ptr.normalized_value_to_string(n, false) };
                let back = unsafe { ptr.string_to_normalized_value(&text) }
                    .unwrap_or_else(|| panic!("{text:?} does not parse back"));
                let again = unsafe { ptr.normalized_value_to_string(back, false) };
                assert_eq!(text, again, "text → value → text changed");
            }
        }
    }

    /// The engine's range of `name` in the group `G`.
    fn range<G: SettingsGroup>(name: &str) -> Range {
        G::FIELDS
            .iter()
            .find(|f| f.name == name)
            .and_then(|f| f.range)
            .unwrap_or_else(|| panic!("no numeric field `{name}`"))
    }

    #[test]
    fn knobs_lie_in_the_engines_ranges_and_start_at_its_defaults() {
        let p = TactusParams::default();
        let d = Settings::default();
        let knobs: [(&FloatParam, Range, f64); 15] = [
            (&p.size, range::<ImpactSettings>("size"), d.impact.size),
            (&p.damping, range::<ImpactSettings>("damping"), d.impact.damping),
            (&p.mass, range::<ImpactSettings>("mass_kg"), d.impact.mass_kg),
            (
                &p.hardness,
                range::<ImpactSettings>("hardness"),
                d.impact.hardness,
            ),
            (
                &p.variation,
                range::<ImpactSettings>("variation"),
                d.impact.variation,
            ),
            (
                &p.scrape_speed,
                range::<ScrapeParams>("speed_m_per_s"),
                d.scrape.speed_m_per_s,
            ),
            (
                &p.scrape_pressure,
                range::<ScrapeParams>("pressure_n"),
                d.scrape.pressure_n,
            ),
            (
                &p.roughness,
                range::<ScrapeParams>("roughness"),
                d.scrape.roughness,
            ),
            (&p.roughness, range::<RollParams>("roughness"), d.roll.roughness),
            (
                &p.roll_speed,
                range::<RollParams>("speed_m_per_s"),
                d.roll.speed_m_per_s,
            ),
            (&p.roll_radius, range::<RollParams>("radius_m"), d.roll.radius_m),
            (
                &p.roll_eccentricity,
                range::<RollParams>("eccentricity"),
                d.roll.eccentricity,
            ),
            (
                &p.roll_pressure,
                range::<RollParams>("pressure_n"),
                d.roll.pressure_n,
            ),
            (
                &p.quality,
                range::<OutputSettings>("quality_db"),
                d.output.quality_db,
            ),
            (&p.gain, range::<OutputSettings>("gain_db"), d.output.gain_db),
        ];
        for (knob, r, default) in knobs {
            let (lo, hi) = (knob.preview_plain(0.0) as f64, knob.preview_plain(1.0) as f64);
            let name = knob.name();
            assert!(
                r.min <= lo && hi <= r.max,
                "{name}: knob {lo}..={hi} outside the engine's {}..={}",
                r.min,
                r.max
            );
            assert_eq!(knob.default_plain_value(), default as f32, "{name}: default");
        }
        let r = range::<OutputSettings>("width");
        assert!(r.min <= p.width.preview_plain(0.0) as f64 && p.width.preview_plain(1.0) as f64 <= r.max);
        assert_eq!(p.width.default_plain_value(), DEFAULT_WIDTH as f32);
        let model: ContactModel = p.contact_model.default_plain_value().into();
        assert_eq!(model, d.impact.contact_model);
        let motion: MotionKind = p.scrape_motion.default_plain_value().into();
        assert_eq!(motion, d.scrape.motion);
        let surface: SurfaceKind = p.surface.default_plain_value().into();
        assert_eq!(surface, d.scrape.surface);
        assert_eq!(surface, d.roll.surface);
    }

    /// The plugin's surface choices are the engine's, in its order, under its names.
    #[test]
    fn surface_choices_follow_the_engine() {
        let ids = SurfaceChoice::ids().expect("ids are given");
        assert_eq!(ids.len(), SurfaceKind::ALL.len());
        for (i, k) in SurfaceKind::ALL.iter().enumerate() {
            assert_eq!(ids[i], k.name());
            assert_eq!(SurfaceKind::from(SurfaceChoice::from_index(i)), *k);
        }
    }
}
