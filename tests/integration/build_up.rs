//! Modes that build up (docs/model.md "Build-up"): the preset field, the engine's pair of
//! resonators against the f64 closed form, re-hits, the mode cap, and the fit's merge of a
//! swelling partial.

use tactus::analysis::signal::Mode;
use tactus::engine::modal::{build_up_pair, ModalBank, ModeParams};
use tactus::engine::reference::{render_build_up_f64, render_modes_f64, snr_db};
use tactus::engine::settings::Settings;
use tactus::fit::recording::modes::{consolidate_attack_free, CONSOLIDATE_REL};
use tactus::preset::*;

use crate::common::{default_strike_force, engine_render, fitted_to, fixed_preset};

const FS: f64 = 48_000.0;

fn mode(freq_hz: f64, level_db: f64, decay_db_per_s: f64, rise_s: f64) -> FixedMode {
    FixedMode {
        freq_hz,
        level_db,
        decay_db_per_s,
        rise_s,
        ring: Default::default(),
    }
}

/// The pair of resonators is the closed form `g·e^{−σt}(1 − e^{−t/τ})·cos ωt` within the bank's
/// f32 output rounding, and it rises: the envelope peaks at `τ·ln(1 + 1/(στ))`, not at 0.
#[test]
fn bank_pair_matches_the_closed_form_build_up() {
    let (decay, rise_s) = (40.0, 0.02);
    let main = ModeParams {
        freq_hz: 440.0,
        decay_db_per_s: decay,
        gain: 0.5,
    };
    let (a, b) = build_up_pair(main, rise_s);
    let pair = [a, b.expect("a build-up has a partner")];
    let len = FS as usize;
    let mut x = vec![0.0f64; 2_001];
    x[0] = 1e-2;
    x[2_000] = 4e-3;
    let reference = render_build_up_f64(&[(main, rise_s)], FS, &x, len);
    let mut bank = ModalBank::with_capacity(2);
    bank.set_sample_rate(FS);
    bank.set_modes(&pair);
    let x32: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    let mut y = vec![0f32; len];
    bank.process(Some(&x32), &mut y[..x32.len()]);
    for chunk in y[x32.len()..].chunks_mut(256) {
        bank.process(None, chunk);
    }
    let y64: Vec<f64> = y.iter().map(|&v| v as f64).collect();
    let snr = snr_db(&reference, &y64);
    println!("pair vs closed form: SNR {snr:.1} dB");
    assert!(snr > 100.0, "SNR {snr:.1} dB");
    // Without the partner it is a different sound: the test can fail.
    let plain = render_modes_f64(&[main], FS, &x, len);
    assert!(snr_db(&reference, &plain) < 20.0);
    // Envelope peak of the first hit (before the second at 2000 samples is irrelevant: the
    // peak time is ~ 50 ms): compare the windowed peak with the closed form's.
    let sigma = decay / (20.0 * std::f64::consts::LOG10_E);
    let t_peak = rise_s * (1.0 + 1.0 / (sigma * rise_s)).ln();
    let env_at = |t: f64| {
        let i = (t * FS) as usize;
        y64[i..i + 110].iter().fold(0.0f64, |m, v| m.max(v.abs()))
    };
    assert!(env_at(0.0) < 0.3 * env_at(t_peak), "no build-up at the onset");
    assert!(env_at(t_peak) > env_at(4.0 * t_peak), "no decay after the peak");
    // No partner for τ = 0.
    assert!(build_up_pair(main, 0.0).1.is_none());
}

/// An engine hit of a mode with a build-up is the contact force convolved with
/// `e^{−σt}(1 − e^{−t/τ})·cos ωt` (f64 reference), up to the output gain.
#[test]
fn engine_hit_builds_up_as_the_f64_reference() {
    let (level_db, decay, rise_s) = (-6.0, 30.0, 0.015);
    let p = fixed_preset(
        "Build-up test",
        "metal",
        vec![mode(523.0, level_db, decay, rise_s)],
    );
    p.validate().unwrap();
    let len = 48_128;
    let (y, _) = engine_render(&p, &[0], len, true);
    let s = Settings::default();
    let x = default_strike_force(&p);
    let m = ModeParams {
        freq_hz: 523.0 / s.impact.size,
        decay_db_per_s: decay * s.impact.damping,
        gain: 10f64.powf(level_db / 20.0),
    };
    let reference = render_build_up_f64(&[(m, rise_s)], FS, &x, len);
    // Output gain (and pan) as one least-squares factor.
    let (scaled, k) = fitted_to(&reference, &y);
    let snr = snr_db(&scaled, &y);
    println!("engine vs f64 build-up reference: SNR {snr:.1} dB (gain factor {k:.4})");
    assert!(snr > 80.0, "SNR {snr:.1} dB");
    // The same mode without its build-up is far from it.
    let plain = render_build_up_f64(&[(m, 0.0)], FS, &x, len);
    let (plain, _) = fitted_to(&plain, &y);
    assert!(snr_db(&plain, &y) < 30.0);
}

/// Re-hits of a ringing object are merged into its voice with the pair matched as one mode:
/// the same sound as stacking voices, on half the mode-samples or less.
#[test]
fn rehits_merge_the_pair_as_one_mode() {
    let p = fixed_preset(
        "Build-up test",
        "metal",
        vec![
            mode(300.0, -6.0, 20.0, 0.01),
            mode(750.0, -10.0, 35.0, 0.004),
            mode(1400.0, -14.0, 50.0, 0.0),
        ],
    );
    let hits: Vec<usize> = (0..6).map(|i| i * 4_000).collect();
    let len = 48_128;
    let (stacked, stacked_ms) = engine_render(&p, &hits, len, false);
    let (merged, merged_ms) = engine_render(&p, &hits, len, true);
    let snr = snr_db(&stacked, &merged);
    println!("stacked {stacked_ms} mode-samples, merged {merged_ms}; SNR {snr:.1} dB");
    assert!(snr > 90.0, "merging changed the sound: SNR {snr:.1} dB");
    assert!(merged_ms * 2 < stacked_ms, "the pairs were not merged");
}

/// Validation names the field (and family) of a bad build-up, counts build-ups against the
/// engine's mode limit, and a file without `rise_s` loads with none.
#[test]
fn rise_fields_validate_by_name_and_round_trip() {
    let p = fixed_preset(
        "Build-up test",
        "metal",
        vec![mode(440.0, -6.0, 20.0, 0.01), mode(880.0, -9.0, 30.0, 0.0)],
    );
    let back = Preset::from_json(&p.to_json(), None).unwrap();
    assert_eq!(back, p);
    assert_eq!(
        p.to_json().matches("rise_s").count(),
        1,
        "zero build-ups are not written"
    );
    let mut bad = p.clone();
    if let ModeModel::Fixed { modes } = &mut bad.modes {
        modes[1].rise_s = -0.5;
    }
    let e = bad.validate().unwrap_err();
    assert_eq!(e.field, "modes.modes[1].rise_s");
    // A distribution in a family: wrong length, out of range.
    let dist = ModeDistribution {
        count: 2,
        gaussian: Gaussian {
            mean: vec![-6.0, -9.0, 3.0, 3.5, 8.8, 9.8],
            covariance: (0..6)
                .map(|i| (0..6).map(|j| if i == j { 0.01 } else { 0.0 }).collect())
                .collect(),
        },
        mean_spacing_octaves: 1.0,
        spacing_tolerance: 0.1,
        decay: DecayCoordinates::Absolute,
        rise_s: vec![0.01, 0.0],
        rings: Vec::new(),
    };
    let mut mix = p.clone();
    mix.families = vec![
        Family {
            name: "a".into(),
            weight: 1.0,
            modes: p.modes.clone(),
            transient: None,
            damping: None,
            dense: None,
            size_class: None,
        },
        Family {
            name: "b".into(),
            weight: 1.0,
            modes: ModeModel::Distribution(dist.clone()),
            transient: None,
            damping: None,
            dense: None,
            size_class: None,
        },
    ];
    mix.validate().expect("valid mixture");
    let back = Preset::from_json(&mix.to_json(), None).unwrap();
    assert_eq!(back, mix);
    let with_rise = |rise_s: Vec<f64>| {
        let mut p = mix.clone();
        p.families[1].modes = ModeModel::Distribution(ModeDistribution {
            rise_s,
            ..dist.clone()
        });
        p.validate().unwrap_err()
    };
    let e = with_rise(vec![0.01, 2.0]);
    assert_eq!(e.field, "families[1].modes.rise_s[1]");
    assert!(e.reason.contains(&MAX_RISE_S.to_string()), "{e}");
    let e = with_rise(vec![0.01]);
    assert_eq!(e.field, "families[1].modes.rise_s");
    assert!(e.reason.contains("expected 2"), "{e}");
    assert_eq!(
        with_rise(vec![f64::NAN, 0.0]).field,
        "families[1].modes.rise_s[0]"
    );
    // Absent field: no build-ups (format 2 file).
    let text = r#"{"format_version": 2, "name": "Old", "material_class": "wood",
        "origin": "fitted", "modes": {"kind": "distribution", "count": 1,
        "gaussian": {"mean": [-6.0, 3.0, 9.0],
                     "covariance": [[1.0, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.01]]},
        "mean_spacing_octaves": 0.0},
        "contact_stiffness_n_per_m": 2e6}"#;
    let old = Preset::from_json(text, None).unwrap();
    let ModeModel::Distribution(d) = &old.modes else {
        unreachable!()
    };
    assert!(d.rise_s.is_empty());
    // Build-ups count against the mode limit: MAX_MODES/2 + 1 modes that all build up.
    let n = tactus::engine::limits::MAX_MODES / 2 + 1;
    let over = fixed_preset(
        "Build-up test",
        "metal",
        (0..n)
            .map(|i| mode(100.0 + 10.0 * i as f64, -6.0, 20.0, 0.01))
            .collect(),
    );
    let e = over.validate().unwrap_err();
    assert_eq!(e.field, "modes.modes");
    assert!(e.reason.contains("build-up"), "{e}");
    let at_cap = fixed_preset(
        "Build-up test",
        "metal",
        (0..n - 1)
            .map(|i| mode(100.0 + 10.0 * i as f64, -6.0, 20.0, 0.01))
            .collect(),
    );
    at_cap.validate().expect("MAX_MODES resonators are allowed");
}

/// A partial that swells (build-up τ) and is extracted as a build-up component plus a
/// near-coincident cancelling copy merges into one mode with the swell's τ and σ: the group's
/// summed signal is `A·e^{−σt}(1 − e^{−t/τ})`, written as the difference of two sinusoids
/// (`c·e^{−σt} − c·e^{−(σ+1/τ)t}`, the second a copy 0.2 % higher) plus a build-up component.
#[test]
fn fit_merges_a_swelling_partial_into_its_rise_and_decay() {
    let np = 20.0 * std::f64::consts::LOG10_E;
    let (f, decay, tau) = (600.0, 25.0, 0.02);
    // Build-up component (the extractor's own τ) carrying the partial...
    let a = Mode {
        freq_hz: f,
        level_db: -6.0,
        decay_db_per_s: decay,
        phase: 0.3,
        attack_s: tau,
        ring: None,
    };
    // ...plus a cancelling pair of copies of the same shape, 12 dB down, without their own
    // build-up: +c at σ, −c at σ + 1/τ.
    let b = Mode {
        freq_hz: f * 1.0005,
        level_db: -18.0,
        decay_db_per_s: decay,
        phase: 0.3,
        attack_s: 0.0,
        ring: None,
    };
    let c = Mode {
        freq_hz: f * 1.001,
        level_db: -18.0,
        decay_db_per_s: decay + np / tau,
        phase: 0.3 + std::f64::consts::PI,
        attack_s: 0.0,
        ring: None,
    };
    let merged = consolidate_attack_free(&[a, b, c], CONSOLIDATE_REL);
    assert_eq!(merged.len(), 1, "{merged:?}");
    let m = merged[0];
    println!("merged: {m:?}");
    assert!(
        (m.decay_db_per_s / decay - 1.0).abs() < 0.1,
        "decay {}",
        m.decay_db_per_s
    );
    assert!((m.attack_s / tau - 1.0).abs() < 0.3, "rise {}", m.attack_s);
    // Energy kept: A² = 2E / ∫env², E of the true summed signal (amplitude 10^(−6/20) +
    // 10^(−18/20) of the same shape, in phase).
    let amp = 10f64.powf(-6.0 / 20.0) + 10f64.powf(-18.0 / 20.0);
    assert!(
        (m.level_db - 20.0 * amp.log10()).abs() < 0.5,
        "level {}",
        m.level_db
    );
    // A group without build-up stays attack-free.
    let plain = consolidate_attack_free(&[Mode { attack_s: 0.0, ..a }, b], CONSOLIDATE_REL);
    assert_eq!(plain.len(), 1);
    assert_eq!(plain[0].attack_s, 0.0);
}

/// Copies whose spectral peaks are one merge whatever their distance in per cent, into one
/// mode carrying their summed signal's energy: a pair 2 % apart at nearly opposite phases and
/// knock-fast decays (as the fit explains an agogo bell's 270 Hz knock) is a weak swell, not
/// two loud partials. A pair as far apart whose peaks are narrower than their distance beats,
/// and stays two.
#[test]
fn fit_merges_copies_whose_peaks_overlap_and_keeps_a_beating_pair() {
    use tactus::fit::recording::extract::synthesize;
    let energy = |modes: &[Mode]| -> f64 { synthesize(modes, FS, FS as usize).iter().map(|v| v * v).sum() };
    let copy = |freq_hz: f64, level_db: f64, decay_db_per_s: f64, phase: f64| Mode {
        freq_hz,
        level_db,
        decay_db_per_s,
        phase,
        attack_s: 0.0,
        ring: None,
    };
    let pair = [copy(268.3, -2.6, 1419.0, -0.57), copy(274.0, -4.1, 1274.0, 2.25)];
    let merged = consolidate_attack_free(&pair, CONSOLIDATE_REL);
    assert_eq!(merged.len(), 1, "{merged:?}");
    let (sum, copies, one) = (
        energy(&pair),
        energy(&pair[..1]) + energy(&pair[1..]),
        energy(&merged),
    );
    let db = |e: f64| 10.0 * e.log10();
    println!(
        "summed signal {:.2} dB, copies apart {:.2} dB, merged mode {:.2} dB",
        db(sum),
        db(copies),
        db(one)
    );
    assert!(
        db(copies) - db(sum) > 6.0,
        "the pair must cancel for the test to mean anything"
    );
    assert!(
        (db(one) - db(sum)).abs() < 1.0,
        "merged {:.2} dB against the sum's {:.2} dB",
        db(one),
        db(sum)
    );
    // 1000 and 1020 Hz: half-power half-widths σ/2π of 11 Hz each at 600 dB/s make one peak;
    // at 300 dB/s (5.5 Hz each) and at 20 dB/s the pair beats.
    for (decay, groups) in [(600.0, 1), (300.0, 2), (20.0, 2)] {
        let m = consolidate_attack_free(
            &[copy(1000.0, -6.0, decay, 0.0), copy(1020.0, -6.0, decay, 0.0)],
            CONSOLIDATE_REL,
        );
        assert_eq!(m.len(), groups, "{decay} dB/s: {m:?}");
    }
}

/// The worst-case build-up preset fills the engine's resonators exactly: MAX_MODES / 2 modes,
/// each a pair, all started by one hit (culling off).
#[test]
fn build_up_pairs_fill_the_mode_cap_exactly() {
    let p = worst_case_build_up_preset();
    p.validate().expect("valid at the cap");
    let (_, mode_samples) = engine_render(&p, &[0], 256, true);
    assert_eq!(mode_samples, (tactus::engine::limits::MAX_MODES * 256) as u64);
}

/// `object::build_up_peak_factor` is the top of the closed-form envelope: the f64 reference's
/// peak after a unit impulse, for build-ups from none to slower than the decay.
#[test]
fn build_up_peak_factor_is_the_envelopes_top() {
    use tactus::engine::object::build_up_peak_factor;
    let x = [1.0];
    for (decay, rise_s) in [
        (60.0, 0.0),
        (60.0, 0.004),
        (300.0, 0.016),
        (700.0, 0.064),
        (20.0, 0.064),
    ] {
        let m = ModeParams {
            freq_hz: 3_000.0,
            decay_db_per_s: decay,
            gain: 1.0,
        };
        let y = render_build_up_f64(&[(m, rise_s)], FS, &x, FS as usize / 2);
        let peak = y.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let factor = build_up_peak_factor(decay, rise_s);
        println!("decay {decay} dB/s, rise {rise_s} s: peak {peak:.4}, factor {factor:.4}");
        assert!(
            (peak / factor - 1.0).abs() < 0.01,
            "peak {peak} vs factor {factor}"
        );
    }
    assert!(
        build_up_peak_factor(700.0, 0.064) < 0.07,
        "a fast decay under a slow build-up peaks low"
    );
}
