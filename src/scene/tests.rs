//! Scene parsing and validation: the format's keys, defaults and error messages.

use super::*;
use crate::engine::force::ContactModel;

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
fn out_of_range_settings_name_field_value_range_and_unit() {
    let cases = [
        (
            r#"{"duration_s": 1, "material": "wood", "settings": {"gain_db": 30}}"#,
            "scene: settings.gain_db must be in -120..=24 dB, got 30",
        ),
        (
            r#"{"duration_s": 1, "material": "wood", "settings": {"width": 1.5}}"#,
            "scene: settings.width must be in 0..=1, got 1.5",
        ),
        (
            r#"{"duration_s": 1, "objects": {"a": {"material": "wood", "settings": {"mass_kg": 0}}}}"#,
            "scene: objects.a.settings.mass_kg must be in 0.000001..=1000 kg, got 0",
        ),
        (
            r#"{"duration_s": 1, "material": "wood", "events": [{"type": "roll", "time_s": 0,
                "duration_s": 0.5, "speed_m_per_s": 0.5, "eccentricity": 0.7}]}"#,
            "scene: events[0].eccentricity must be in 0..=0.5, got 0.7",
        ),
        (
            r#"{"duration_s": 1, "material": "wood", "events": [{"type": "scrape", "time_s": 0,
                "duration_s": 0.5, "speed_m_per_s": 11}]}"#,
            "scene: events[0].speed_m_per_s must be in 0..=10 m/s, got 11",
        ),
    ];
    for (scene, msg) in cases {
        let e = Scene::parse(scene, None).unwrap_err();
        assert_eq!(e.to_string(), msg);
    }
    let e = Scene::parse(
        r#"{"duration_s": 1, "material": "wood", "settings": {"contact_model": "glue"}}"#,
        None,
    )
    .unwrap_err();
    assert!(
        e.to_string()
            .contains("settings.contact_model: unknown variant `glue`"),
        "{e}"
    );
}

/// The contact `ev` (an event's JSON object) parses to, in a one-object scene.
fn parse_contact(ev: &serde_json::Value) -> anyhow::Result<ContactParams> {
    let scene = serde_json::json!({"duration_s": 2, "material": "wood", "events": [ev]});
    let loaded = Scene::from_value(scene, None)?;
    Ok(loaded.scene.events[0].contact().expect("a contact event").params)
}

/// Every field of `P`'s table is a key of a `kind` event, sets that field, and is checked
/// against its range: a new `settings_group!` line needs no change in the scene format.
fn every_table_field_is_an_event_key<P: SettingsGroup + PartialEq>(kind: &str) {
    let own = ContactEvent::<P>::OWN_KEYS;
    let base = serde_json::json!({"type": kind, "time_s": 0, "duration_s": 1, "speed_m_per_s": 0.5});
    let plain = parse_contact(&base).unwrap();
    // A switch or choice has no range to pick a value from: the first of these its type
    // accepts that is not its default.
    let choices = [
        serde_json::json!("circular"),
        serde_json::json!("hunt_crossley"),
        serde_json::json!("sandpaper"),
        serde_json::json!(true),
        serde_json::json!(false),
    ];
    for f in P::FIELDS {
        assert!(
            f.name == "speed_m_per_s" || !own.contains(&f.name),
            "{kind}: field `{}` is shadowed by the event's own key",
            f.name
        );
        let value = match f.range {
            Some(r) => {
                // The range's minimum, or its maximum where the default is the minimum.
                let min = serde_json::json!(r.min);
                let mut probe = P::default();
                probe.set_json(f.name, &min).unwrap().unwrap();
                if probe == P::default() {
                    serde_json::json!(r.max)
                } else {
                    min
                }
            }
            None => choices
                .iter()
                .find(|v| {
                    let mut probe = P::default();
                    matches!(probe.set_json(f.name, v), Some(Ok(()))) && probe != P::default()
                })
                .unwrap_or_else(|| panic!("{kind}: add a non-default value for `{}`", f.name))
                .clone(),
        };
        let mut ev = base.clone();
        ev[f.name] = value.clone();
        if f.name != "speed_m_per_s" {
            // A preset motion takes a constant speed, which the base event gives.
            let got = parse_contact(&ev).unwrap_or_else(|e| panic!("{kind}.{}: {e}", f.name));
            assert_ne!(got, plain, "{kind}: key `{}` = {value} changed nothing", f.name);
        }
        if let Some(r) = f.range {
            ev[f.name] = serde_json::json!(r.max * 2.0 + 1.0);
            let e = parse_contact(&ev).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("scene: events[0].{} must be in ", f.name)),
                "{kind}.{}: {e}",
                f.name
            );
        }
    }
}

#[test]
fn contact_events_read_every_field_of_their_settings_table() {
    every_table_field_is_an_event_key::<ScrapeParams>("scrape");
    every_table_field_is_an_event_key::<RollParams>("roll");
}

#[test]
fn contact_event_keys_are_checked_like_a_derived_struct() {
    let parse = |ev: &str| {
        let scene = format!(r#"{{"duration_s": 2, "material": "wood", "events": [{ev}]}}"#);
        Scene::parse(&scene, None).unwrap_err().to_string()
    };
    let cases = [
        (
            r#"{"type": "roll", "time_s": 0, "duration_s": 1, "motion": "manual"}"#,
            "unknown field `motion`, expected one of `object`, `time_s`, `duration_s`, \
             `speed_m_per_s`, `speed_curve`, `pressure_n`, `roughness`, `surface`, \
             `radius_m`, `eccentricity`",
        ),
        (
            r#"{"type": "scrape", "time_s": 0, "duration_s": 1, "radius_m": 1}"#,
            "unknown field `radius_m`, expected one of `object`, `time_s`, `duration_s`, \
             `speed_m_per_s`, `speed_curve`, `motion`, `pressure_n`, `roughness`, `surface`",
        ),
        (
            r#"{"type": "scrape", "time_s": 0, "duration_s": 1, "roughness": 1, "roughness": 0}"#,
            "duplicate field `roughness`",
        ),
        (
            r#"{"type": "roll", "time_s": 0, "speed_m_per_s": 1}"#,
            "missing field `duration_s`",
        ),
        (
            r#"{"type": "roll", "time_s": 0, "duration_s": 1, "speed_m_per_s": 1, "pressure_n": null}"#,
            "invalid type: null, expected f64",
        ),
    ];
    for (ev, msg) in cases {
        let e = parse(ev);
        assert!(e.contains(msg), "{ev}: {e}");
    }
    let c = parse_contact(&serde_json::json!({"type": "roll", "time_s": 0, "duration_s": 1,
        "speed_curve": [[0, 1]], "radius_m": 0.03, "object": null}))
    .unwrap();
    let want = RollParams {
        speed_m_per_s: 0.0,
        radius_m: 0.03,
        ..RollParams::default()
    };
    assert_eq!(
        c,
        ContactParams::Roll(want),
        "a curve leaves the constant speed 0"
    );
}

#[test]
fn object_settings_override_the_scenes_field_by_field() {
    let s = Scene::parse(
        r#"{"duration_s": 1, "settings": {"size": 2, "gain_db": -6, "contact_model": "raised_cosine"},
            "ablation": {"morphing": false},
            "objects": {"a": {"material": "wood", "settings": {"size": 0.5}},
                        "b": {"material": "wood"}}}"#,
        None,
    )
    .unwrap();
    let a = s.scene.object_settings(&s.scene.objects["a"].settings);
    let b = s.scene.object_settings(&s.scene.objects["b"].settings);
    assert_eq!((a.impact.size, b.impact.size), (0.5, 2.0));
    assert_eq!((a.output.gain_db, b.output.gain_db), (-6.0, -6.0));
    assert_eq!(a.impact.contact_model, ContactModel::RaisedCosine);
    assert_eq!(a.impact.damping, Settings::default().impact.damping);
    assert!(!a.ablation.morphing && !b.ablation.morphing);
    assert_eq!(
        (a.scrape.pressure_n, a.roll.pressure_n),
        (0.0, 0.0),
        "no contact outside events"
    );
}

#[test]
fn render_is_deterministic_and_block_size_independent() {
    let s = Scene::parse(DEMO_SCENE, None).unwrap();
    let mut short = s.clone();
    short.scene.duration_s = 1.5;
    let (a, _) = render(&short, 512);
    let (b, _) = render(&short, 512);
    let (c, _) = render(&short, 37);
    assert_eq!(a, b);
    let peak = a.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    assert!(peak > 1e-3, "render is silent");
    let max_diff = a.iter().zip(&c).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
    // Block size moves only where the bank's f32 output projection rounds (2⁻²⁴ of each
    // mode's amplitude, not of the sum's peak: an object whose loud modes partly cancel
    // shows a larger ratio to its peak; docs/model.md and the README give the measured
    // figures). A real block-size bug, such as an event one sample late, differs by ~1e-2.
    // Bound: −100 dB re full scale.
    assert!(
        max_diff <= 1e-5,
        "block size changed output by {max_diff} (peak {peak})"
    );
}
