//! Shipped presets: every built-in validates, names/order are fixed, and the recordings check
//! (skipped when /work/shared/recordings is absent).

use tactus::engine::materials::builtin_presets;

#[test]
fn builtins_load_and_validate_in_order() {
    let names: Vec<String> = builtin_presets().iter().map(|p| p.name.clone()).collect();
    assert_eq!(
        names,
        [
            "Wood",
            "Metal",
            "Glass",
            "Ceramic",
            "Plastic",
            "Stone",
            "Cardboard"
        ]
    );
    for p in builtin_presets() {
        p.validate().unwrap_or_else(|e| panic!("{}: {e}", p.name));
    }
}

use crate::common::pool_one_family;
use tactus::analysis::signal::Mode;
use tactus::fit::pool::distribution::{ContactCompensation, MAX_CONTACT_BOOST_DB};
use tactus::fit::recording::modes::{max_mode_decay_db_per_s, split_modes};
use tactus::fit::recording::{fit_signal, FileResult};
use tactus::preset::ModeModel;

fn mode(freq_hz: f64, level_db: f64, decay_db_per_s: f64) -> Mode {
    Mode {
        freq_hz,
        level_db,
        decay_db_per_s,
        phase: 0.0,
        attack_s: 0.0,
        ring: None,
    }
}

fn result(name: &str, modes: Vec<Mode>) -> FileResult {
    FileResult {
        name: name.into(),
        fs: 44_100.0,
        ringing: tactus::fit::recording::ringing_modes(&modes, &[], 44_100.0, 44_100),
        modes,
        attack_s: 0.0,
        transient: vec![Some((-40.0, 300.0)); tactus::fit::recording::bands::BANDS],
        ringing_transient: vec![Some((-40.0, 300.0)); tactus::fit::recording::bands::BANDS],
        dense_transient: None,
        distance_db: 1.0,
        note: String::new(),
        dense: Default::default(),
        censored: false,
    }
}

/// The default strike's contact is the engine's: a 50 g striker at 1 m/s on the preset's
/// stiffness through the default Hunt–Crossley contact, whose lossless duration is
/// `2.943·x₀/v` for Hertz's exponent (the default damping shortens it by a few per cent); the
/// boost is the inverse of the envelope the engine weights its transient bands with, capped.
#[test]
fn contact_compensation_is_the_default_strike() {
    use tactus::engine::force::{hunt_crossley_stiffness, HC_DEFAULT_EXPONENT};
    let k = 2.0e6;
    let c = ContactCompensation::default_strike(k, HC_DEFAULT_EXPONENT);
    let (m, v, a) = (0.05f64, 1.0f64, HC_DEFAULT_EXPONENT);
    let x0 = ((a + 1.0) * m * v * v / (2.0 * hunt_crossley_stiffness(k, a))).powf(1.0 / (a + 1.0));
    let tau = 2.943 * x0 / v;
    assert!(
        (c.duration_s / tau - 1.0).abs() < 0.1,
        "{} vs {tau}",
        c.duration_s
    );
    let tau = c.duration_s;
    assert!(c.boost_db(0.0).abs() < 1e-12);
    assert!((c.boost_db(1.0 / (2.0 * tau)) - 10.0 * 2f64.log10()).abs() < 1e-6);
    assert_eq!(c.boost_db(1.0e5), MAX_CONTACT_BOOST_DB);
    // A contact that stiffens faster with compression (larger exponent) is a different strike.
    assert_ne!(
        ContactCompensation::default_strike(k, 1.2).duration_s,
        c.duration_s
    );
}

/// Fitted levels are raised by the default contact's attenuation at each mode's frequency, so
/// the default hit, which applies it again, reproduces the recordings' balance.
#[test]
fn fitted_levels_undo_the_default_contact() {
    let files: Vec<FileResult> = (0..4)
        .map(|i| {
            let s = 1.0 + 0.01 * i as f64;
            result(
                &format!("wood_bar_{i}.wav"),
                vec![
                    mode(300.0 * s, -20.0, 20.0),
                    mode(1000.0 * s, -20.0, 40.0),
                    mode(3000.0 * s, -20.0, 80.0),
                ],
            )
        })
        .collect();
    let p = pool_one_family("wood", &files, 3).expect("fit");
    let ModeModel::Distribution(d) = &p.modes else {
        panic!("not a distribution")
    };
    let c = ContactCompensation::default_strike(p.contact_stiffness_n_per_m, p.contact_exponent);
    let f = |i: usize| d.gaussian.mean[2 * d.count + i].exp2();
    let want = c.boost_db(f(2)) - c.boost_db(f(0));
    let got = d.gaussian.mean[2] - d.gaussian.mean[0];
    println!("3 kHz re 300 Hz: fitted {got:.2} dB, contact boost {want:.2} dB");
    assert!(
        want > 10.0,
        "the test needs a strong contact roll-off ({want:.1} dB)"
    );
    assert!((got - want).abs() < 0.1, "fitted {got:.2} dB, want {want:.2} dB");
}

/// A component that dies faster than a one-ERB noise band at its frequency is strike noise,
/// one below 20 Hz or the analysis' resolution is drift: neither is a mode.
#[test]
fn strike_noise_and_sub_audio_components_are_not_modes() {
    let fs = 44_100.0;
    let comps = vec![
        mode(0.009, 0.0, 1.0),
        mode(1.2, 0.0, 3.0),
        mode(25.0, -10.0, 5.0),
        mode(440.0, -10.0, 30.0),
        mode(500.0, -6.0, 1.5 * max_mode_decay_db_per_s(500.0)),
        mode(2000.0, -20.0, f64::NAN),
    ];
    // One second analysed: 25 Hz is resolved; half a second would not resolve below 2 Hz.
    let (modes, noise) = split_modes(&comps, fs, fs as usize);
    let f: Vec<f64> = modes.iter().map(|m| m.freq_hz).collect();
    assert_eq!(f, vec![25.0, 440.0]);
    assert_eq!(noise.len(), 1);
    assert_eq!(noise[0].freq_hz, 500.0);
    let (modes, _) = split_modes(&comps, fs, 1000);
    assert!(modes.iter().all(|m| m.freq_hz >= 44.1), "{modes:?}");
}

/// A recording with a DC offset and a 1.2 Hz drift under its modes (as handling noise gives)
/// fits without any sub-audio mode, and the preset fitted from such files is finite.
#[test]
fn drift_under_a_recording_never_becomes_a_mode() {
    let fs = 44_100.0;
    let n = fs as usize;
    let files: Vec<FileResult> = (0..3)
        .map(|k| {
            let s = 1.0 + 0.03 * k as f64;
            let x: Vec<f64> = (0..n)
                .map(|i| {
                    let t = i as f64 / fs;
                    let m = |f: f64, a: f64, d: f64| {
                        a * (-d / 8.686 * t).exp() * (std::f64::consts::TAU * f * s * t).sin()
                    };
                    0.2 + 0.3 * (std::f64::consts::TAU * 1.2 * t).sin()
                        + m(440.0, 0.4, 30.0)
                        + m(1130.0, 0.2, 50.0)
                        + m(2710.0, 0.1, 90.0)
                })
                .collect();
            fit_signal(&x, fs, &format!("metal_bell_{k}.wav"), String::new(), false)
        })
        .collect();
    for r in &files {
        let low = r.modes.iter().map(|m| m.freq_hz).fold(f64::INFINITY, f64::min);
        println!("{}: {} modes, lowest {low:.2} Hz", r.name, r.modes.len());
        assert!(low >= 20.0, "{}: mode at {low} Hz", r.name);
    }
    let p = pool_one_family("metal", &files, 3).expect("a finite preset");
    assert!(p.to_json().len() > 10);
}

/// A recording whose modes are not numbers yields an error that says so, not a preset that
/// fails validation on an internal field name.
#[test]
fn non_finite_modes_are_a_readable_error() {
    let files = vec![
        result(
            "a.wav",
            vec![mode(300.0, -20.0, 20.0), mode(900.0, f64::NAN, 40.0)],
        ),
        result("b.wav", vec![mode(310.0, -20.0, 20.0), mode(950.0, -25.0, 40.0)]),
    ];
    let e = pool_one_family("wood", &files, 2).unwrap_err().to_string();
    assert!(e.contains("not finite"), "{e}");
    assert!(!e.contains("gaussian.mean"), "{e}");
}

/// A preset pools the partials the evaluation hears: a weak partial that rings for a second is
/// a mode even where the joint fit found no component, a partial whose component the strike
/// dominated gets its measured decay and energy, and a component dying within one track frame
/// is left to the transient. The components here are what the joint fit gave such a signal
/// (marimba C5: no component at its 785 Hz partial; steel drum C6: 655 dB/s where the partial
/// rings at 10 dB/s).
#[test]
fn pooled_modes_are_the_partials_measured_on_the_signal() {
    use tactus::analysis::partials::peaks_and_partials;
    use tactus::analysis::signal::energy_db;
    use tactus::fit::recording::extract::synthesize;
    use tactus::fit::recording::{ringing_decay_limit_db_per_s, ringing_modes};
    let fs = 44_100.0;
    let truth = [
        mode(261.0, 0.0, 40.0),
        mode(520.0, -20.0, 10.0),
        mode(785.0, -30.0, 40.0),
    ];
    let y = synthesize(&truth, fs, (1.5 * fs) as usize);
    let components = [
        mode(261.0, 0.0, 40.0),
        mode(521.5, 13.0, 655.0),
        mode(3000.0, 6.0, 3000.0),
    ];
    let pooled = ringing_modes(&components, &peaks_and_partials(&y, fs).1, fs, y.len());
    assert!(
        pooled
            .iter()
            .all(|m| m.decay_db_per_s <= ringing_decay_limit_db_per_s(m.freq_hz)),
        "{pooled:?}"
    );
    assert!(
        !pooled.iter().any(|m| (m.freq_hz - 3000.0).abs() < 50.0),
        "{pooled:?}"
    );
    assert_eq!(pooled.len(), 3, "{pooled:?}");
    for t in &truth {
        let m = pooled
            .iter()
            .find(|m| (m.freq_hz - t.freq_hz).abs() < 5.0)
            .unwrap_or_else(|| panic!("no mode at {} Hz: {pooled:?}", t.freq_hz));
        assert!(
            (m.decay_db_per_s / t.decay_db_per_s - 1.0).abs() < 0.15,
            "{} Hz decays at {} dB/s, truth {}",
            t.freq_hz,
            m.decay_db_per_s,
            t.decay_db_per_s
        );
        assert!(
            (energy_db(m) - energy_db(t)).abs() < 1.5,
            "{} Hz: energy {:.2} dB, truth {:.2} dB",
            t.freq_hz,
            energy_db(m),
            energy_db(t)
        );
    }
}

/// A preset's transient leaves out what outlasts its modes: over a mode at 30 dB/s, a strike
/// burst and a stationary noise floor, the gap fitted without a bound has bands that barely decay
/// (the floor), and with the pipeline's bound (half the slowest mode's decay) those bands are
/// gone while the strike's high bands stay.
#[test]
fn a_presets_transient_leaves_out_what_outlasts_its_modes() {
    use tactus::fit::recording::extract::synthesize;
    use tactus::fit::recording::transient::{fit_transient_gap, fit_transient_gap_decaying, GapDecay};
    let fs = 44_100.0;
    let n = (1.5 * fs) as usize;
    let modal = synthesize(&[mode(440.0, 0.0, 30.0)], fs, n);
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut noise = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    // The strike: differenced noise (rising 6 dB per octave, so the floor dominates the low
    // bands) dying at 600 dB/s; the floor: white noise.
    let mut last = 0.0;
    let y: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            let w = noise();
            let strike = (w - last) * 10f64.powf(-600.0 * t / 20.0);
            last = w;
            modal[i] + 0.3 * strike + 0.003 * noise()
        })
        .collect();
    let slow = |bands: &[Option<(f64, f64)>]| bands.iter().flatten().filter(|b| b.1 < 15.0).count();
    let free = fit_transient_gap(&y, &modal, fs);
    let bounded = fit_transient_gap_decaying(&y, &modal, fs, 15.0, GapDecay::Line);
    eprintln!(
        "bands decaying under 15 dB/s: {} unbounded, {} bounded; kept {} of {}",
        slow(&free),
        slow(&bounded),
        bounded.iter().flatten().count(),
        free.iter().flatten().count()
    );
    assert!(slow(&free) > 0, "the floor should show as slow bands: {free:?}");
    assert_eq!(slow(&bounded), 0, "{bounded:?}");
    // The strike's bands above the mode keep a fast decay.
    assert!(
        bounded.iter().skip(20).flatten().all(|b| b.1 > 100.0)
            && bounded.iter().skip(20).flatten().count() >= 5,
        "{bounded:?}"
    );
}

/// A component's levels are normalised by its strongest mode as heard, at the top of its
/// envelope: a mode that builds up over 64 ms and dies at 700 dB/s peaks 24 dB under its onset
/// level, so a ringing mode 10 dB under that onset level is the one set to the gain staging's
/// level, and the object plays as loud as one without build-ups.
#[test]
fn a_component_is_normalised_by_its_strongest_envelope_peak() {
    use tactus::engine::object::build_up_peak_factor;
    use tactus::fit::pool::distribution::{fit_exemplar, ExemplarKernel, TOP_LEVEL_DB};
    let swelling = Mode {
        attack_s: 0.064,
        ring: None,
        ..mode(400.0, 0.0, 700.0)
    };
    let modes = [swelling, mode(1_000.0, -10.0, 50.0)];
    let (d, shift) = fit_exemplar(&modes, 2, None, ExemplarKernel { size_sd_octaves: 0.0 }).expect("fits");
    let swell = 20.0 * build_up_peak_factor(700.0, 0.064).log10();
    assert!(
        swell < -20.0,
        "the swelling mode peaks {swell:.1} dB under its onset level"
    );
    // Ordered by frequency: the swelling mode first.
    let (a, b) = (d.gaussian.mean[0], d.gaussian.mean[1]);
    assert!((b - TOP_LEVEL_DB).abs() < 1e-9, "ringing mode at {b} dB");
    assert!(
        (a - (TOP_LEVEL_DB + 10.0)).abs() < 1e-9,
        "swelling mode at {a} dB"
    );
    assert!((shift - (TOP_LEVEL_DB + 10.0)).abs() < 1e-9, "shift {shift} dB");
}

/// Decays stored relative to a damping law come back as fitted: a draw multiplies by the same
/// floored law the fit divided by. The law here is the one fitted to a crash cymbal's modes
/// (`α2·ω³`), which falls to 3·10⁻⁶ dB/s at 63 Hz and 0.002 dB/s at 535 Hz, far under the floor
/// ([`MIN_LAW_DECAY_DB_PER_S`]): a draw that multiplied by the unfloored law would play the
/// cymbal's 535 Hz strike mode (1450 dB/s, a T60 of 41 ms) at 51 dB/s, and its 63 Hz mode
/// would not decay at all.
#[test]
fn decays_relative_to_a_damping_law_draw_as_fitted() {
    use rand::SeedableRng;
    use tactus::engine::object::{EngineRng, ObjectSampler, SampledObject};
    use tactus::fit::pool::distribution::{fit_exemplar, ExemplarKernel};
    use tactus::preset::{DampingModel, MIN_LAW_DECAY_DB_PER_S};
    let law = DampingModel {
        alpha1: 2.5e-16,
        alpha2: 1.06e-14,
        alpha3: 1.5,
        sigma: 0.0,
        eta: 0.0,
    };
    assert!(law.decay_db_per_s(535.0) < MIN_LAW_DECAY_DB_PER_S);
    let fitted = [
        mode(63.3, -30.0, 7.8),
        mode(535.0, -6.0, 1450.0),
        mode(4_800.0, -10.0, 120.0),
        mode(9_900.0, -12.0, 114.0),
    ];
    let (mut d, _) =
        fit_exemplar(&fitted, 4, Some(&law), ExemplarKernel { size_sd_octaves: 0.0 }).expect("fits");
    // No spread: each drawn mode is the fitted one.
    for (i, row) in d.gaussian.covariance.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = if i == j { 1e-12 } else { 0.0 };
        }
    }
    let mut preset = builtin_presets()[1].clone();
    preset.modes = ModeModel::Distribution(d);
    preset.damping = Some(law);
    preset.transient = None;
    preset.families.clear();
    preset.validate().expect("valid preset");
    let mut sampler = ObjectSampler::new(&preset);
    let mut object = SampledObject::with_capacity();
    sampler.sample(&mut EngineRng::seed_from_u64(1), &mut object);
    assert_eq!(object.modes.len(), fitted.len());
    for (drawn, fit) in object.modes.iter().zip(&fitted) {
        let ratio = drawn.decay_db_per_s / fit.decay_db_per_s;
        assert!(
            (ratio - 1.0).abs() < 1e-3,
            "{:.1} Hz: fitted {} dB/s, drawn {:.4} dB/s",
            fit.freq_hz,
            fit.decay_db_per_s,
            drawn.decay_db_per_s
        );
    }
}
