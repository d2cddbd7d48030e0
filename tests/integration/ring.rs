//! Modes that ring after their knock (docs/model.md "Ring"): the preset field, the engine's
//! pair of resonators against the f64 two-stage decay, and the mode cap.

use tactus::engine::modal::ModeParams;
use tactus::engine::reference::{render_modes_f64, snr_db};
use tactus::engine::settings::Settings;
use tactus::preset::*;

use crate::common::{default_strike_force, engine_render, fitted_to, fixed_preset};

const FS: f64 = 48_000.0;

fn mode(freq_hz: f64, level_db: f64, decay_db_per_s: f64, ring: ModeRing) -> FixedMode {
    FixedMode {
        freq_hz,
        level_db,
        decay_db_per_s,
        rise_s: 0.0,
        ring,
    }
}

/// An engine hit of a mode with a ring is the contact force convolved with
/// `g·((1 − s)·e^{−σt} + s·e^{−rσt})·cos ωt`, written here as two f64 modes, up to the output
/// gain; without the ring it is another sound.
#[test]
fn engine_hit_rings_as_the_f64_two_stage_reference() {
    let (level_db, decay) = (-6.0, 600.0);
    let ring = ModeRing {
        share: 0.12,
        decay_ratio: 0.2,
    };
    let p = fixed_preset("Ring test", "wood", vec![mode(750.0, level_db, decay, ring)]);
    p.validate().unwrap();
    let len = 24_064;
    let (y, _) = engine_render(&p, &[0], len, true);
    let (_, first_block) = engine_render(&p, &[0], 256, true);
    assert_eq!(first_block, 2 * 256, "the ring is a second resonator");
    let s = Settings::default();
    let x = default_strike_force(&p);
    let (freq_hz, g, k) = (
        750.0 / s.impact.size,
        10f64.powf(level_db / 20.0),
        decay * s.impact.damping,
    );
    let stages = [
        ModeParams {
            freq_hz,
            decay_db_per_s: k,
            gain: 0.88 * g,
        },
        ModeParams {
            freq_hz,
            decay_db_per_s: 0.2 * k,
            gain: 0.12 * g,
        },
    ];
    let (reference, _) = fitted_to(&render_modes_f64(&stages, FS, &x, len), &y);
    let snr = snr_db(&reference, &y);
    println!("engine vs f64 two-stage reference: SNR {snr:.1} dB");
    assert!(snr > 80.0, "SNR {snr:.1} dB");
    // The ring is what rings 0.1 s on: the knock alone is ~60 dB down by then, the pair ~28 dB.
    let energy = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>();
    let (early, late) = (energy(&y[..480]), energy(&y[4_800..5_280]));
    let fall_db = 10.0 * (early / late).log10();
    println!("fall from the first to the 100 ms window: {fall_db:.1} dB");
    assert!((20.0..35.0).contains(&fall_db), "fall {fall_db:.1} dB");
    let (knock, _) = fitted_to(&render_modes_f64(&stages[..1], FS, &x, len), &y);
    assert!(snr_db(&knock, &y) < 20.0, "the ring made no difference");
}

/// Validation names the field of a bad ring, refuses a mode that both builds up and rings,
/// counts rings against the engine's mode limit; rings round-trip, and a file without them
/// writes and reads none.
#[test]
fn ring_fields_validate_by_name_and_round_trip() {
    let ring = ModeRing {
        share: 0.1,
        decay_ratio: 0.25,
    };
    let p = fixed_preset(
        "Ring test",
        "wood",
        vec![
            mode(440.0, -6.0, 300.0, ring),
            mode(880.0, -9.0, 400.0, ModeRing::default()),
        ],
    );
    p.validate().unwrap();
    let back = Preset::from_json(&p.to_json(), None).unwrap();
    assert_eq!(back, p);
    assert_eq!(
        p.to_json().matches("\"ring\"").count(),
        1,
        "no ring is not written"
    );
    let with = |f: &dyn Fn(&mut FixedMode)| {
        let mut b = p.clone();
        if let ModeModel::Fixed { modes } = &mut b.modes {
            f(&mut modes[0]);
        }
        b.validate().map(|_| ()).unwrap_err().field
    };
    assert_eq!(with(&|m| m.ring.share = 0.95), "modes.modes[0].ring.share");
    assert_eq!(with(&|m| m.ring.share = -0.1), "modes.modes[0].ring.share");
    assert_eq!(
        with(&|m| m.ring.decay_ratio = 1.0),
        "modes.modes[0].ring.decay_ratio"
    );
    assert_eq!(
        with(&|m| m.ring.decay_ratio = f64::NAN),
        "modes.modes[0].ring.decay_ratio"
    );
    assert_eq!(with(&|m| m.rise_s = 0.01), "modes.modes[0]");
    // A distribution: rings of the wrong length are refused.
    let mut d = worst_case_ring_preset();
    d.validate().expect("valid at the cap");
    if let ModeModel::Distribution(dist) = &mut d.modes {
        dist.rings.pop();
    }
    assert_eq!(d.validate().unwrap_err().field, "modes.rings");
    // A version-5 file (no rings) loads with none.
    let json = fixed_preset(
        "Ring test",
        "wood",
        vec![mode(440.0, -6.0, 300.0, ModeRing::default())],
    )
    .to_json()
    .replace(
        &format!("\"format_version\": {FORMAT_VERSION}"),
        "\"format_version\": 5",
    );
    let old = Preset::from_json(&json, None).expect("a version-5 file loads");
    assert_eq!(old.format_version, 5);
}

/// The worst-case ring preset fills the engine's resonators exactly: every distribution mode a
/// pair, the dense field the rest, all started by one hit (culling off).
#[test]
fn ring_pairs_fill_the_mode_cap_exactly() {
    let p = worst_case_ring_preset();
    p.validate().expect("valid at the cap");
    let (_, mode_samples) = engine_render(&p, &[0], 256, true);
    assert_eq!(mode_samples, (tactus::engine::limits::MAX_MODES * 256) as u64);
}
