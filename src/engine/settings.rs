//! The engine's one settings model: every control in physical units, grouped as the engine uses
//! it (impact, scrape, roll, output, ablation). The plugin fills it from its parameters once per
//! block, scenes deserialise it (src/scene.rs maps the scene's flat `settings` object onto it),
//! the benchmarks and tests build it directly.
//!
//! Each field is declared once, in a `settings_group!` block: its type, its default and, for a
//! number, its valid range and unit. From that one line come the struct field, its default,
//! [`Settings::sanitized`] (the engine's safe fallback: out-of-range values clamp to the range,
//! non-finite ones take the fallback, so nothing reaches the DSP that it does not handle),
//! [`Settings::validate`] (the strict check for inputs a user typed, such as scenes, which must
//! not be clamped silently) and the field-by-name access the scene format uses.

use super::force::ContactModel;
use super::limits::{MAX_CONTACT_SPEED_M_PER_S, MAX_PRESSURE_N};
use super::sustained::{MotionKind, SurfaceKind};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use std::fmt;

/// The valid range of a numeric setting, in the unit its name carries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// Smallest valid value.
    pub min: f64,
    /// Largest valid value.
    pub max: f64,
    /// Unit for messages ("" for a plain factor).
    pub unit: &'static str,
}

/// One field of a settings group: its name (the serde name) and, for a number, its range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldSpec {
    /// Field name, as in Rust and in JSON.
    pub name: &'static str,
    /// Valid range of a numeric field; `None` for switches and choices (every value is valid).
    pub range: Option<Range>,
}

/// A setting outside its range: names the field path, the value, the range and the unit.
#[derive(Debug, Clone, PartialEq)]
pub struct SettingError {
    /// Path of the field, e.g. `settings.gain_db` or `events[2].pressure_n`.
    pub path: String,
    /// The rejected value.
    pub value: f64,
    /// The valid range.
    pub range: Range,
}

impl fmt::Display for SettingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let Range { min, max, unit } = self.range;
        let sep = if unit.is_empty() { "" } else { " " };
        write!(
            f,
            "{} must be in {min}..={max}{sep}{unit}, got {}",
            self.path, self.value
        )
    }
}

impl std::error::Error for SettingError {}

/// What a settings field's type needs: numbers clamp and check against their range; switches
/// and choices (no range) pass through unchanged.
pub trait SettingValue: Copy + DeserializeOwned {
    /// The value clamped into `range`; `fallback` when it is not a finite number.
    fn sanitize(self, _range: Option<Range>, _fallback: Self) -> Self {
        self
    }
    /// The value as a number, and the range, when it lies outside `range` (or is not finite).
    fn out_of_range(self, _range: Option<Range>) -> Option<(f64, Range)> {
        None
    }
}

impl SettingValue for f64 {
    fn sanitize(self, range: Option<Range>, fallback: Self) -> Self {
        match range {
            Some(r) => clamp_finite(self, r.min, r.max, fallback),
            None => self,
        }
    }
    fn out_of_range(self, range: Option<Range>) -> Option<(f64, Range)> {
        let r = range?;
        (!self.is_finite() || self < r.min || self > r.max).then_some((self, r))
    }
}

impl SettingValue for u32 {
    fn sanitize(self, range: Option<Range>, _fallback: Self) -> Self {
        match range {
            Some(r) => (self as f64).clamp(r.min, r.max) as u32,
            None => self,
        }
    }
    fn out_of_range(self, range: Option<Range>) -> Option<(f64, Range)> {
        let r = range?;
        let v = self as f64;
        (v < r.min || v > r.max).then_some((v, r))
    }
}

impl SettingValue for bool {}
impl SettingValue for ContactModel {}
impl SettingValue for MotionKind {}
impl SettingValue for SurfaceKind {}

/// A settings group's fields by name, from its `settings_group!` lines: how scenes read a group
/// without naming its fields (a scene's flat `settings` object, and every key of a scrape or
/// roll event that is not the event's own), so a new field line is a scene key with no other
/// change.
pub trait SettingsGroup: Default + Copy {
    /// The fields in declaration order, with their ranges.
    const FIELDS: &'static [FieldSpec];

    /// Sets the field called `name` from JSON; `None` if the group has no such field.
    fn set_json(&mut self, name: &str, value: &serde_json::Value) -> Option<Result<(), serde_json::Error>>;

    /// Copies the field called `name` from `from`; false if the group has no such field.
    fn copy_field(&mut self, from: &Self, name: &str) -> bool;
}

/// `v` clamped to `lo..=hi`; `fallback` when `v` is not finite.
pub(crate) fn clamp_finite(v: f64, lo: f64, hi: f64, fallback: f64) -> f64 {
    if v.is_finite() {
        v.clamp(lo, hi)
    } else {
        fallback
    }
}

/// `Some(Range)` from a field line's optional `[min, max] "unit"`.
macro_rules! setting_range {
    () => {
        None
    };
    ($lo:expr, $hi:expr, $unit:literal) => {
        Some(Range {
            min: $lo,
            max: $hi,
            unit: $unit,
        })
    };
}

/// The non-finite fallback of a field line: its `non_finite = …` if given, else its default.
macro_rules! setting_fallback {
    ($default:expr) => {
        $default
    };
    ($default:expr, $fallback:expr) => {
        $fallback
    };
}

/// Declares a settings group: one line per field,
/// `pub name: Type = default, [min, max] "unit", non_finite = fallback;` (range and unit for
/// numbers only; `non_finite` only where the fallback is not the default). Generates the struct
/// (serde: every field optional, unknown fields rejected), its `Default`, `sanitized`,
/// `validate` and its [`SettingsGroup`] table (`FIELDS`, `set_json`, `copy_field`).
macro_rules! settings_group {
    (
        $(#[$meta:meta])*
        pub struct $group:ident {
            $(
                $(#[$fmeta:meta])*
                pub $field:ident: $ty:ty = $default:expr
                    $(, [$lo:expr, $hi:expr] $unit:literal $(, non_finite = $fb:expr)?)?;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
        #[serde(default, deny_unknown_fields)]
        pub struct $group {
            $(
                $(#[$fmeta])*
                pub $field: $ty,
            )*
        }

        impl Default for $group {
            fn default() -> Self {
                Self {
                    $($field: $default,)*
                }
            }
        }

        impl $group {
            /// Every number clamped to its range; a non-finite one replaced by its fallback.
            pub fn sanitized(&self) -> Self {
                Self {
                    $($field: SettingValue::sanitize(
                        self.$field,
                        setting_range!($($lo, $hi, $unit)?),
                        setting_fallback!($default $($(, $fb)?)?),
                    ),)*
                }
            }

            /// The first field outside its range, named `{at}.{field}` (`{field}` if `at` is
            /// empty).
            pub fn validate(&self, at: &str) -> Result<(), SettingError> {
                $(
                    if let Some((value, range)) =
                        SettingValue::out_of_range(self.$field, setting_range!($($lo, $hi, $unit)?))
                    {
                        return Err(SettingError {
                            path: field_path(at, stringify!($field)),
                            value,
                            range,
                        });
                    }
                )*
                Ok(())
            }
        }

        impl SettingsGroup for $group {
            const FIELDS: &'static [FieldSpec] = &[
                $(FieldSpec {
                    name: stringify!($field),
                    range: setting_range!($($lo, $hi, $unit)?),
                },)*
            ];

            fn set_json(
                &mut self,
                name: &str,
                value: &serde_json::Value,
            ) -> Option<Result<(), serde_json::Error>> {
                match name {
                    $(stringify!($field) => Some(
                        <$ty as Deserialize>::deserialize(value).map(|v| self.$field = v),
                    ),)*
                    _ => None,
                }
            }

            fn copy_field(&mut self, from: &Self, name: &str) -> bool {
                match name {
                    $(stringify!($field) => {
                        self.$field = from.$field;
                        true
                    })*
                    _ => false,
                }
            }
        }
    };
}

/// Macros and helpers a settings group outside this file (the gestures') is declared with.
pub(crate) use {setting_fallback, setting_range, settings_group};

pub(crate) fn field_path(at: &str, name: &str) -> String {
    if at.is_empty() {
        name.to_string()
    } else {
        format!("{at}.{name}")
    }
}

settings_group! {
    /// The struck object and the striker (docs/model.md §2–3).
    pub struct ImpactSettings {
        /// Object scale (1 = the preset's reference object); mode frequencies scale as 1/size.
        pub size: f64 = 1.0, [0.01, 100.0] "";
        /// Decay multiplier: the preset's decays in dB/s are multiplied by this (1 = as
        /// measured, < 1 rings longer, 0 = never decays).
        pub damping: f64 = 1.0, [0.0, 100.0] "";
        /// Striker mass in kg.
        pub mass_kg: f64 = 0.05, [1e-6, 1e3] "kg";
        /// Contact stiffness multiplier on the preset's `contact_stiffness_n_per_m`.
        pub hardness: f64 = 1.0, [1e-4, 1e4] "";
        /// Impact contact model. Hunt–Crossley by default: its contact shortens as the strike
        /// speeds up, so a harder strike is brighter, as real strikes are (docs/model.md §5).
        pub contact_model: ContactModel = ContactModel::HuntCrossley;
        /// Re-hit variation: SD of onset-power noise as a fraction of the mean mode power
        /// (0.2 = Traer).
        pub variation: f64 = 0.2, [0.0, 2.0] "";
    }
}

settings_group! {
    /// The scraping contact (docs/model.md §6). A speed or pressure that is not a number
    /// falls back to 0: no scraping, rather than a default contact nobody asked for.
    pub struct ScrapeParams {
        /// Scraping speed in m/s: peak speed of a preset motion; manual speed when no
        /// per-sample buffer is given. 0 = no scraping.
        pub speed_m_per_s: f64 = 0.0, [0.0, MAX_CONTACT_SPEED_M_PER_S] "m/s", non_finite = 0.0;
        /// Scraping motion.
        pub motion: MotionKind = MotionKind::Manual;
        /// Mean normal force of the scraper in N. 0 = no scraping.
        pub pressure_n: f64 = 5.0, [0.0, MAX_PRESSURE_N] "N", non_finite = 0.0;
        /// Roughness 0..=1 (RMS height 0..10 µm) of the surface under the scraper. Each contact
        /// has its own, so a scrape and a roll of one scene keep their events' values.
        pub roughness: f64 = 0.5, [0.0, 1.0] "";
        /// The surface under the scraper: `synthetic` (its RMS height set by `roughness`) or a
        /// measured one (`pvc`, `sandpaper`, …; docs/model.md §6), endless per seed.
        pub surface: SurfaceKind = SurfaceKind::Synthetic;
    }
}

settings_group! {
    /// The rolling ball (docs/model.md §7). A speed or weight that is not a number falls back
    /// to 0: no rolling. The lines' order is the order a scene's roll event lists its keys in
    /// an error (after the event's own), the README's order.
    pub struct RollParams {
        /// Ball centre speed in m/s. 0 = no rolling.
        pub speed_m_per_s: f64 = 0.0, [0.0, MAX_CONTACT_SPEED_M_PER_S] "m/s", non_finite = 0.0;
        /// Ball weight (mean normal force) in N. 0 = no rolling.
        pub pressure_n: f64 = 2.0, [0.0, MAX_PRESSURE_N] "N", non_finite = 0.0;
        /// Roughness 0..=1 (RMS height 0..10 µm) of the surface under the ball.
        pub roughness: f64 = 0.5, [0.0, 1.0] "";
        /// The surface under the ball, as the scrape's `surface`.
        pub surface: SurfaceKind = SurfaceKind::Synthetic;
        /// Ball mean radius in m.
        pub radius_m: f64 = 0.02, [0.001, 1.0] "m";
        /// Ball centre-of-mass offset r/R.
        pub eccentricity: f64 = 0.1, [0.0, 0.5] "";
    }
}

settings_group! {
    /// What is computed and how loud it comes out.
    pub struct OutputSettings {
        /// Perceptual culling: modes more than this many dB below the strongest are not
        /// computed.
        pub quality_db: f64 = 60.0, [1.0, 300.0] "dB";
        /// Output gain in dB, applied to everything that sounds (ringing modes, transients,
        /// scraping, rolling) after the synthesis, ramped over [`super::GAIN_RAMP_S`] so changes
        /// never click.
        pub gain_db: f64 = 0.0, [-120.0, 24.0] "dB";
        /// Stereo width 0..=1 (docs/model.md "Stereo pickups"): 0 = one pickup (identical
        /// channels), 1 = two independent pickups. Ramped over [`super::stereo::WIDTH_RAMP_S`].
        /// Why 0 here: scenes and engine users written before the setting were mono and keep
        /// their sound; the plugin starts new instances at [`super::stereo::DEFAULT_WIDTH`].
        pub width: f64 = 0.0, [0.0, 1.0] "";
    }
}

settings_group! {
    /// Ablation switches of the sustained-contact model (Agarwal et al. 2021's comparisons).
    pub struct Ablation {
        /// tanh curvature limit + Gaussian smoothing of the trajectory (eq. 4–5).
        pub curvature_limit: bool = true;
        /// Normal force varying with the motion / ball rotation (else held at the mean).
        pub varying_normal_force: bool = true;
        /// Only the surface's IR (no scraper / ball IR weighted by η).
        pub surface_ir_only: bool = false;
        /// Position-dependent IR morphing (§2.4).
        pub morphing: bool = true;
    }
}

/// Control values of the engine, in physical units. Filled by the plugin from its parameters
/// once per block, by the CLI from a scene. The engine works on [`Settings::sanitized`]; inputs
/// a user typed are checked with [`Settings::validate`] first.
#[derive(Debug, Clone, Copy, PartialEq, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Settings {
    /// The struck object and the striker.
    pub impact: ImpactSettings,
    /// The scraping contact.
    pub scrape: ScrapeParams,
    /// The rolling contact.
    pub roll: RollParams,
    /// Culling and output gain.
    pub output: OutputSettings,
    /// The sustained-contact model's comparison switches.
    pub ablation: Ablation,
}

impl Settings {
    /// Every field clamped to its range; non-finite values replaced by the field's fallback
    /// (its default, or 0 for the contacts' speeds and forces).
    pub fn sanitized(&self) -> Settings {
        Settings {
            impact: self.impact.sanitized(),
            scrape: self.scrape.sanitized(),
            roll: self.roll.sanitized(),
            output: self.output.sanitized(),
            ablation: self.ablation.sanitized(),
        }
    }

    /// The first field outside its range, named by its path under `at` (e.g.
    /// `settings.scrape.pressure_n`).
    pub fn validate(&self, at: &str) -> Result<(), SettingError> {
        self.impact.validate(&field_path(at, "impact"))?;
        self.scrape.validate(&field_path(at, "scrape"))?;
        self.roll.validate(&field_path(at, "roll"))?;
        self.output.validate(&field_path(at, "output"))?;
        self.ablation.validate(&field_path(at, "ablation"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_lie_in_their_ranges() {
        let d = Settings::default();
        assert_eq!(d.validate(""), Ok(()));
        assert_eq!(d.sanitized(), d);
    }

    #[test]
    fn sanitized_clamps_and_replaces_non_finite_values() {
        let mut s = Settings::default();
        s.impact.size = 1e9;
        s.impact.damping = f64::NAN;
        s.scrape.pressure_n = f64::INFINITY;
        s.roll.speed_m_per_s = -3.0;
        s.output.gain_db = f64::NEG_INFINITY;
        let c = s.sanitized();
        assert_eq!(c.impact.size, 100.0);
        assert_eq!(c.impact.damping, 1.0, "non-finite → default");
        assert_eq!(c.scrape.pressure_n, 0.0, "non-finite force → no contact");
        assert_eq!(c.roll.speed_m_per_s, 0.0);
        assert_eq!(c.output.gain_db, 0.0);
        assert_eq!(c.validate(""), Ok(()));
    }

    #[test]
    fn validation_names_path_value_range_and_unit() {
        let mut s = Settings::default();
        s.roll.pressure_n = 1500.0;
        let e = s.validate("settings").unwrap_err();
        assert_eq!(
            e.to_string(),
            "settings.roll.pressure_n must be in 0..=1000 N, got 1500"
        );
        s.roll.pressure_n = 2.0;
        s.impact.variation = f64::NAN;
        let e = s.validate("").unwrap_err();
        assert_eq!(e.to_string(), "impact.variation must be in 0..=2, got NaN");
    }

    #[test]
    fn deserialises_nested_json_and_rejects_unknown_fields() {
        let s: Settings = serde_json::from_str(
            r#"{"impact": {"size": 2, "contact_model": "raised_cosine"}, "roll": {"radius_m": 0.05},
                "ablation": {"morphing": false}}"#,
        )
        .unwrap();
        assert_eq!(s.impact.size, 2.0);
        assert_eq!(s.impact.contact_model, ContactModel::RaisedCosine);
        assert_eq!(s.impact.damping, 1.0);
        assert_eq!(s.roll.radius_m, 0.05);
        assert!(!s.ablation.morphing && s.ablation.curvature_limit);
        let e = serde_json::from_str::<Settings>(r#"{"impact": {"sise": 2}}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field `sise`"), "{e}");
    }

    #[test]
    fn fields_by_name() {
        let mut s = ImpactSettings::default();
        assert!(s.set_json("mass_kg", &serde_json::json!(0.2)).unwrap().is_ok());
        assert_eq!(s.mass_kg, 0.2);
        assert!(s
            .set_json("mass_kg", &serde_json::json!("heavy"))
            .unwrap()
            .is_err());
        assert!(s.set_json("gain_db", &serde_json::json!(1)).is_none());
        let mut t = ImpactSettings::default();
        assert!(t.copy_field(&s, "mass_kg") && !t.copy_field(&s, "nope"));
        assert_eq!(t, s);
        let names: Vec<&str> = OutputSettings::FIELDS.iter().map(|f| f.name).collect();
        assert_eq!(names, ["quality_db", "gain_db", "width"]);
    }
}
