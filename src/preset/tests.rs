//! Preset format, validation and error messages: the JSON round trip, each range and
//! shape check naming its field, and the worst-case presets the engine is sized for.

use super::*;

fn fixed() -> Preset {
    Preset {
        format_version: FORMAT_VERSION,
        name: "Test".into(),
        material_class: "metal".into(),
        origin: Origin::Provisional,
        provenance: Provenance::default(),
        modes: ModeModel::Fixed {
            modes: vec![FixedMode {
                freq_hz: 440.0,
                level_db: -10.0,
                decay_db_per_s: 20.0,
                rise_s: 0.0,
                ring: Default::default(),
            }],
        },
        transient: None,
        damping: None,
        contact_stiffness_n_per_m: 1e6,
        contact_exponent: crate::engine::force::HC_DEFAULT_EXPONENT,
        families: Vec::new(),
        dense: None,
    }
}

#[test]
fn round_trips_through_json() {
    let p = fixed();
    let back = Preset::from_json(&p.to_json(), None).unwrap();
    assert_eq!(p, back);
}

#[test]
fn errors_name_field_and_file() {
    let mut p = fixed();
    if let ModeModel::Fixed { modes } = &mut p.modes {
        modes[0].freq_hz = f64::NAN;
    }
    let text = serde_json::to_string(&p).unwrap().replace("null", "\"x\"");
    let e = Preset::from_json(&text, Some("a.json")).unwrap_err();
    assert_eq!(e.file.as_deref(), Some("a.json"));
    let mut p = fixed();
    p.contact_stiffness_n_per_m = -3.0;
    let e = Preset::from_json(&p.to_json(), Some("b.json")).unwrap_err();
    assert_eq!(e.field, "contact_stiffness_n_per_m");
    assert!(e.to_string().contains("b.json"));
}

#[test]
fn rejects_non_positive_definite_covariance() {
    let mut p = fixed();
    p.modes = ModeModel::Distribution(ModeDistribution {
        count: 1,
        gaussian: Gaussian {
            mean: vec![-10.0, 3.0, 9.0],
            covariance: vec![vec![1.0, 2.0, 0.0], vec![2.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]],
        },
        mean_spacing_octaves: 0.5,
        spacing_tolerance: 0.1,
        decay: DecayCoordinates::Absolute,
        rise_s: Vec::new(),
        rings: Vec::new(),
    });
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "modes.gaussian.covariance");
    assert!(e.reason.contains("positive definite"));
}

/// A format-1 file (no `families`, no `decay`) loads with the format-1 meaning: one
/// distribution, absolute decays, its version kept.
#[test]
fn format_1_distribution_loads_unchanged() {
    let text = r#"{"format_version": 1, "name": "Old", "material_class": "wood",
        "origin": "fitted", "modes": {"kind": "distribution", "count": 1,
        "gaussian": {"mean": [-6.0, 3.0, 9.0],
                     "covariance": [[1.0, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]]},
        "mean_spacing_octaves": 0.0},
        "contact_stiffness_n_per_m": 2e6}"#;
    let p = Preset::from_json(text, Some("old.json")).expect("format 1 loads");
    assert_eq!(p.format_version, 1);
    assert!(p.families.is_empty());
    let ModeModel::Distribution(d) = &p.modes else {
        panic!("not a distribution")
    };
    assert_eq!(d.decay, DecayCoordinates::Absolute);
    assert!(!p.to_json().contains("families"));
}

#[test]
fn family_and_decay_errors_name_the_field() {
    let mut p = fixed();
    p.modes = ModeModel::Distribution(ModeDistribution {
        count: 1,
        gaussian: Gaussian {
            mean: vec![-10.0, 0.0, 9.0],
            covariance: vec![vec![1.0, 0.0, 0.0], vec![0.0, 1.0, 0.0], vec![0.0, 0.0, 1.0]],
        },
        mean_spacing_octaves: 0.0,
        spacing_tolerance: 0.1,
        decay: DecayCoordinates::DampingResidual,
        rise_s: Vec::new(),
        rings: Vec::new(),
    });
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "modes.decay");
    assert!(e.reason.contains("damping law"), "{e}");
    let mut p = fixed();
    p.families = vec![Family {
        name: "bars".into(),
        weight: 0.0,
        modes: p.modes.clone(),
        transient: None,
        damping: None,
        dense: None,
        size_class: None,
    }];
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "families[0].weight");
    p.families[0].weight = 2.0;
    if let ModeModel::Fixed { modes } = &mut p.families[0].modes {
        modes[0].freq_hz = 1.0;
    }
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "families[0].modes.modes[0].freq_hz");
}

#[test]
fn mode_and_band_counts_stop_at_the_engine_limits() {
    let worst = worst_case_preset();
    worst.validate().expect("the worst case is a valid preset");
    let mut p = worst.clone();
    let ModeModel::Distribution(d) = &mut p.modes else {
        unreachable!()
    };
    d.count = MAX_DISTRIBUTION_MODES + 1;
    d.gaussian.mean.resize(3 * d.count, 0.0);
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "modes.count");
    assert!(
        e.reason.contains(&format!("1..={MAX_DISTRIBUTION_MODES}"))
            && e.reason.contains(&(MAX_DISTRIBUTION_MODES + 1).to_string()),
        "{e}"
    );
    let mut p = fixed();
    let one = match &p.modes {
        ModeModel::Fixed { modes } => modes[0],
        _ => unreachable!(),
    };
    p.modes = ModeModel::Fixed {
        modes: vec![one; MAX_MODES + 1],
    };
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "modes.modes");
    assert!(e.reason.contains(&MAX_MODES.to_string()), "{e}");
    let mut p = worst;
    p.transient.as_mut().unwrap().bands = MAX_BANDS + 1;
    let e = p.validate().unwrap_err();
    assert_eq!(e.field, "transient.bands");
    assert!(e.reason.contains(&format!("1..={MAX_BANDS}")), "{e}");
}
