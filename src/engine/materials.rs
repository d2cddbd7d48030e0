//! Built-in materials. Wood, Metal and the object families are fitted from recordings (the JSON
//! files under presets/), the measured materials from measured mode tables (presets/measured/);
//! the others are *derived* from Sterling et al.'s Table 1.1 Rayleigh
//! damping (docs/model.md §4) and a physically reasoned, log-spaced mode-frequency distribution
//! with a shared size factor.

use crate::preset::{
    DampingModel, Gaussian, ModeDistribution, ModeModel, Origin, Preset, Provenance, TransientDistribution,
    FORMAT_VERSION,
};

/// Parameters of a derived material.
#[derive(Debug, Clone, Copy)]
pub struct DerivedSpec {
    /// Display name.
    pub name: &'static str,
    /// Material class.
    pub class: &'static str,
    /// Rayleigh α1 (1/s).
    pub alpha1: f64,
    /// Rayleigh α2 (s).
    pub alpha2: f64,
    /// Lowest and highest mean mode frequency, Hz.
    pub freq_range_hz: (f64, f64),
    /// Number of modes.
    pub count: usize,
    /// Level tilt in dB per octave above the lowest mode.
    pub tilt_db_per_octave: f64,
    /// Contact stiffness, N/m.
    pub stiffness: f64,
    /// Transient onset level (dB) and decay (dB/s).
    pub transient: (f64, f64),
}

/// Standard deviations of the derived Gaussians. Why these values: per-object level scatter of
/// a few dB and ±25 % decay scatter are typical of Traer's pooled measurements; the shared
/// frequency factor (0.15 octave) models object-size variation within a material, the
/// independent part (0.04 octave) inharmonic scatter of single modes.
const LEVEL_SD_DB: f64 = 4.0;
const LN_DECAY_SD: f64 = 0.25;
const SHARED_LOG2F_SD: f64 = 0.15;
const OWN_LOG2F_SD: f64 = 0.04;

/// Builds a derived preset from a spec.
pub fn derived(spec: &DerivedSpec) -> Preset {
    let m = spec.count;
    let damping = DampingModel {
        alpha1: spec.alpha1,
        alpha2: spec.alpha2,
        alpha3: 1.0,
        sigma: 0.0,
        eta: 0.0,
    };
    let (lo, hi) = (spec.freq_range_hz.0.log2(), spec.freq_range_hz.1.log2());
    let mut mean = vec![0.0; 3 * m];
    for i in 0..m {
        let t = if m > 1 { i as f64 / (m - 1) as f64 } else { 0.0 };
        // Modes crowd toward high frequencies (plate-like density): square-root spacing in log f.
        let lf = lo + (hi - lo) * t.sqrt();
        let f = lf.exp2();
        mean[i] = -6.0 + spec.tilt_db_per_octave * (lf - lo);
        mean[m + i] = damping.decay_db_per_s(f).max(0.05).ln();
        mean[2 * m + i] = lf;
    }
    let n = 3 * m;
    let mut cov = vec![vec![0.0; n]; n];
    for i in 0..m {
        cov[i][i] = LEVEL_SD_DB * LEVEL_SD_DB;
        cov[m + i][m + i] = LN_DECAY_SD * LN_DECAY_SD;
        for j in 0..m {
            cov[2 * m + i][2 * m + j] = SHARED_LOG2F_SD * SHARED_LOG2F_SD;
        }
        cov[2 * m + i][2 * m + i] += OWN_LOG2F_SD * OWN_LOG2F_SD;
    }
    let spacing = {
        let f: Vec<f64> = (0..m).map(|i| mean[2 * m + i]).collect();
        if m > 1 {
            (f[m - 1] - f[0]) / (m - 1) as f64
        } else {
            0.0
        }
    };
    let bands = 30;
    let mut tmean = vec![spec.transient.0; 2 * bands];
    for v in &mut tmean[bands..] {
        *v = spec.transient.1.ln();
    }
    let mut tcov = vec![vec![0.0; 2 * bands]; 2 * bands];
    for i in 0..bands {
        tcov[i][i] = 9.0;
        tcov[bands + i][bands + i] = 0.04;
    }
    Preset {
        format_version: FORMAT_VERSION,
        name: spec.name.into(),
        material_class: spec.class.into(),
        origin: Origin::Provisional,
        provenance: Provenance {
            sources: vec!["Sterling et al. 2019, Table 1.1 (Rayleigh damping)".into()],
            method: "derived: Rayleigh damping over log-spaced modes with a shared size factor".into(),
            date: "2026-11-22".into(),
            tool_version: env!("CARGO_PKG_VERSION").into(),
            notes: "derived, not fitted: no recordings of this material in the DEV set (docs/presets.md); Rayleigh damping from Sterling 2019 Table 1.1, log-spaced modes".into(),
        },
        modes: ModeModel::Distribution(ModeDistribution {
            count: m,
            gaussian: Gaussian {
                mean,
                covariance: cov,
            },
            mean_spacing_octaves: spacing,
            spacing_tolerance: 0.10,
            decay: crate::preset::DecayCoordinates::Absolute,
            rise_s: Vec::new(),
            rings: Vec::new(),
        }),
        transient: Some(TransientDistribution {
            bands,
            low_hz: 50.0,
            high_hz: 16_000.0,
            gaussian: Gaussian {
                mean: tmean,
                covariance: tcov,
            },
        }),
        damping: Some(damping),
        contact_stiffness_n_per_m: spec.stiffness,
        contact_exponent: crate::engine::force::HC_DEFAULT_EXPONENT,
        families: Vec::new(),
        dense: None,
    }
}

/// The built-in materials, in `material` parameter order (the plugin's list is fixed to these
/// names plus a final user slot, so saved projects keep their material).
pub const BUILTIN_SPECS: [DerivedSpec; 7] = [
    spec(
        "Wood",
        "wood",
        39.0,
        1.3e-7,
        (350.0, 6_000.0),
        24,
        -4.0,
        2.0e6,
        (-30.0, 400.0),
    ),
    spec(
        "Metal",
        "metal",
        2.3,
        6.9e-8,
        (400.0, 12_000.0),
        32,
        -2.0,
        2.0e7,
        (-36.0, 600.0),
    ),
    spec(
        "Glass",
        "glass",
        2.0,
        7.8e-8,
        (900.0, 14_000.0),
        24,
        -3.0,
        3.0e7,
        (-36.0, 800.0),
    ),
    // Porcelain row of Table 1.1.
    spec(
        "Ceramic",
        "ceramic",
        3.9,
        1.0e-8,
        (700.0, 12_000.0),
        24,
        -3.0,
        2.5e7,
        (-34.0, 700.0),
    ),
    spec(
        "Plastic",
        "plastic",
        39.8,
        1.3e-7,
        (300.0, 6_000.0),
        20,
        -5.0,
        1.0e6,
        (-28.0, 350.0),
    ),
    // Travertine row of Table 1.1.
    spec(
        "Stone",
        "stone",
        1.3,
        2.5e-8,
        (500.0, 10_000.0),
        24,
        -4.0,
        3.0e7,
        (-32.0, 600.0),
    ),
    // Not in Table 1.1: cardboard is far more damped than wood; α's chosen so a 1 kHz mode
    // dies in ~0.05 s (c ≈ 280/s), matching the short thuds of boxes.
    spec(
        "Cardboard",
        "cardboard",
        200.0,
        2.0e-6,
        (150.0, 3_000.0),
        16,
        -6.0,
        2.0e5,
        (-24.0, 250.0),
    ),
];

#[allow(clippy::too_many_arguments)]
const fn spec(
    name: &'static str,
    class: &'static str,
    alpha1: f64,
    alpha2: f64,
    freq_range_hz: (f64, f64),
    count: usize,
    tilt_db_per_octave: f64,
    stiffness: f64,
    transient: (f64, f64),
) -> DerivedSpec {
    DerivedSpec {
        name,
        class,
        alpha1,
        alpha2,
        freq_range_hz,
        count,
        tilt_db_per_octave,
        stiffness,
        transient,
    }
}

/// The built-in specs whose presets are derived, not fitted (Wood and Metal are fitted by
/// `tactus fit` from recordings, docs/presets.md).
pub fn derived_specs() -> impl Iterator<Item = &'static DerivedSpec> {
    const FITTED: [&str; 2] = ["wood", "metal"];
    BUILTIN_SPECS.iter().filter(|s| !FITTED.contains(&s.class))
}

/// The file `presets/<class>.json` of a derived spec holds: [`derived`] as JSON.
pub fn derived_preset_json(spec: &DerivedSpec) -> String {
    let mut preset = derived(spec);
    preset.origin = crate::preset::Origin::Derived;
    preset.to_json() + "\n"
}

/// All built-in presets, in `material` parameter order.
/// Loaded from the shipped `presets/*.json` (embedded at build time): Wood and Metal are fitted
/// by `tactus fit` from recordings, the others are derived (written from [`BUILTIN_SPECS`]).
pub fn builtin_presets() -> Vec<Preset> {
    SHIPPED
        .iter()
        .map(|(name, text)| {
            Preset::from_json(text, Some(name)).unwrap_or_else(|e| panic!("shipped preset: {e}"))
        })
        .collect()
}

/// The shipped preset files, in `material` parameter order.
const SHIPPED: [(&str, &str); 7] = [
    ("presets/wood.json", include_str!("../../presets/wood.json")),
    ("presets/metal.json", include_str!("../../presets/metal.json")),
    ("presets/glass.json", include_str!("../../presets/glass.json")),
    ("presets/ceramic.json", include_str!("../../presets/ceramic.json")),
    ("presets/plastic.json", include_str!("../../presets/plastic.json")),
    ("presets/stone.json", include_str!("../../presets/stone.json")),
    (
        "presets/cardboard.json",
        include_str!("../../presets/cardboard.json"),
    ),
];

/// Display names of the fitted single-family presets, in the order they follow the user slot
/// in the plugin's `material` parameter (appended, so saved projects keep their material).
pub const FAMILY_PRESET_NAMES: [&str; 10] = [
    "Marimba Bar",
    "Wood Block",
    "Claves",
    "Cowbell",
    "Steel Pan",
    "Ride Cymbal",
    "Crash Cymbal",
    "China Cymbal",
    "Splash Cymbal",
    "Agogo Bell",
];

/// The fitted single-family presets (one kind of object each, fitted by `tactus fit` from that
/// family's recordings, docs/presets.md), in [`FAMILY_PRESET_NAMES`] order.
pub fn family_presets() -> Vec<Preset> {
    FAMILY_SHIPPED
        .iter()
        .map(|(name, text)| {
            Preset::from_json(text, Some(name)).unwrap_or_else(|e| panic!("shipped preset: {e}"))
        })
        .collect()
}

/// Every shipped preset: [`builtin_presets`], then [`family_presets`], then
/// [`measured_presets`] (names for scenes and the CLI).
pub fn shipped_presets() -> Vec<Preset> {
    let mut v = builtin_presets();
    v.extend(family_presets());
    v.extend(measured_presets());
    v
}

/// Display names of the materials fitted from measured mode tables of everyday objects
/// (docs/measured.md), in the order they follow the family presets in the plugin's
/// `material` parameter (appended, so saved projects keep their material). "(measured)" tells
/// them from the derived Glass, Ceramic, Plastic, Stone and Cardboard, which stay as the
/// long-ringing variants (plates and tiles of Sterling's damping table).
pub const MEASURED_PRESET_NAMES: [&str; 14] = [
    "Ceramic (measured)",
    "Glass (measured)",
    "Stone (measured)",
    "Metal (measured)",
    "Hard Wood (measured)",
    "Medium Wood (measured)",
    "Soft Wood (measured)",
    "Hard Plastic (measured)",
    "Soft Plastic Foam (measured)",
    "Rubber (measured)",
    "Cardboard (measured)",
    "Paper (measured)",
    "Leather (measured)",
    "Fabric (measured)",
];

/// The materials fitted by `tactus fit` from the measured mode tables of Traer et al. 2019
/// (presets/measured/refit.sh), in [`MEASURED_PRESET_NAMES`] order.
pub fn measured_presets() -> Vec<Preset> {
    MEASURED_SHIPPED
        .iter()
        .map(|(name, text)| {
            Preset::from_json(text, Some(name)).unwrap_or_else(|e| panic!("shipped preset: {e}"))
        })
        .collect()
}

const MEASURED_SHIPPED: [(&str, &str); 14] = [
    (
        "presets/measured/ceramic.json",
        include_str!("../../presets/measured/ceramic.json"),
    ),
    (
        "presets/measured/glass.json",
        include_str!("../../presets/measured/glass.json"),
    ),
    (
        "presets/measured/stone.json",
        include_str!("../../presets/measured/stone.json"),
    ),
    (
        "presets/measured/metal.json",
        include_str!("../../presets/measured/metal.json"),
    ),
    (
        "presets/measured/wood-hard.json",
        include_str!("../../presets/measured/wood-hard.json"),
    ),
    (
        "presets/measured/wood-medium.json",
        include_str!("../../presets/measured/wood-medium.json"),
    ),
    (
        "presets/measured/wood-soft.json",
        include_str!("../../presets/measured/wood-soft.json"),
    ),
    (
        "presets/measured/plastic-hard.json",
        include_str!("../../presets/measured/plastic-hard.json"),
    ),
    (
        "presets/measured/plastic-soft-foam.json",
        include_str!("../../presets/measured/plastic-soft-foam.json"),
    ),
    (
        "presets/measured/rubber.json",
        include_str!("../../presets/measured/rubber.json"),
    ),
    (
        "presets/measured/cardboard.json",
        include_str!("../../presets/measured/cardboard.json"),
    ),
    (
        "presets/measured/paper.json",
        include_str!("../../presets/measured/paper.json"),
    ),
    (
        "presets/measured/leather.json",
        include_str!("../../presets/measured/leather.json"),
    ),
    (
        "presets/measured/fabric.json",
        include_str!("../../presets/measured/fabric.json"),
    ),
];

const FAMILY_SHIPPED: [(&str, &str); 10] = [
    (
        "presets/marimba-bar.json",
        include_str!("../../presets/marimba-bar.json"),
    ),
    (
        "presets/wood-block.json",
        include_str!("../../presets/wood-block.json"),
    ),
    ("presets/claves.json", include_str!("../../presets/claves.json")),
    ("presets/cowbell.json", include_str!("../../presets/cowbell.json")),
    (
        "presets/steel-pan.json",
        include_str!("../../presets/steel-pan.json"),
    ),
    (
        "presets/ride-cymbal.json",
        include_str!("../../presets/ride-cymbal.json"),
    ),
    (
        "presets/crash-cymbal.json",
        include_str!("../../presets/crash-cymbal.json"),
    ),
    (
        "presets/china-cymbal.json",
        include_str!("../../presets/china-cymbal.json"),
    ),
    (
        "presets/splash-cymbal.json",
        include_str!("../../presets/splash-cymbal.json"),
    ),
    (
        "presets/agogo-bell.json",
        include_str!("../../presets/agogo-bell.json"),
    ),
];

#[cfg(test)]
mod tests {
    #[test]
    fn builtins_validate() {
        for p in super::shipped_presets() {
            p.validate().unwrap_or_else(|e| panic!("{}: {e}", p.name));
        }
        let names: Vec<String> = super::family_presets().into_iter().map(|p| p.name).collect();
        assert_eq!(names, super::FAMILY_PRESET_NAMES);
        let names: Vec<String> = super::measured_presets().into_iter().map(|p| p.name).collect();
        assert_eq!(names, super::MEASURED_PRESET_NAMES);
    }
}
