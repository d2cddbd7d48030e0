//! Impact tests: contact-force accuracy against analytic and fine f64 references (docs/model.md §5)
//! and object sampling statistics (§3). The engine's handling of impacts (voices, culling,
//! re-strikes, robustness) is in tests/integration/impacts_engine.rs.

use tactus::engine::dsp::linalg::cholesky;
use tactus::engine::force::{
    hunt_crossley_stiffness, ContactModel, ImpactForce, ImpactParams, HC_DEFAULT_DAMPING_S_PER_M,
    HC_DEFAULT_EXPONENT,
};
use tactus::engine::materials::{builtin_presets, family_presets};
use tactus::engine::object::{
    amplitude_sum_db, draw, mean_object_modes, peak_amplitude_sum_db, perturb_levels, transient_energy_db,
    EngineRng, ObjectSampler, SampledObject,
};
use tactus::engine::Settings;
use tactus::preset::{DampingModel, ModeModel};

use rand::SeedableRng;

use crate::common;
use crate::common::render_one_hit;
/// Renders a whole contact at `sr`; returns the generator and the impulse per sample.
fn render_force(p: &ImpactParams, sr: f64) -> (ImpactForce, Vec<f64>) {
    let mut f = ImpactForce::default();
    f.start(p, sr);
    let summary_only = f.clone();
    let mut out = Vec::new();
    let mut buf = vec![0f32; 4096];
    while f.is_active() {
        f.fill(&mut buf);
        out.extend(buf.iter().map(|&v| v as f64));
        assert!(out.len() < 100_000_000, "contact never ends");
    }
    (summary_only, out)
}

/// Duration (s, from the last non-zero sample) and peak force (N, mean force over the sample
/// with the largest impulse) measured from the rendered signal.
fn measure(out: &[f64], sr: f64) -> (f64, f64) {
    let last = out.iter().rposition(|&v| v != 0.0).unwrap();
    let peak = out.iter().cloned().fold(0.0, f64::max) * sr;
    ((last + 1) as f64 / sr, peak)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn spring_and_raised_cosine_match_analytic() {
    // 10 MHz "sample rate": 1-sample resolution is < 0.02 % of these contacts.
    let sr = 1.0e7;
    for (m, v, k) in [(0.05f64, 1.0f64, 1e6f64), (0.5, 3.0, 2e5), (0.01, 0.2, 1e7)] {
        let tau = std::f64::consts::PI * (m / k).sqrt();
        for (model, peak) in [
            (ContactModel::Spring, v * (k * m).sqrt()),
            (ContactModel::RaisedCosine, 4.0 * m * v / tau),
        ] {
            let (_, out) = render_force(&ImpactParams::new(m, v, k, model), sr);
            let (d, p) = measure(&out, sr);
            let j: f64 = out.iter().sum();
            println!(
                "{model:?} m={m} v={v} k={k}: duration err {:.2e}, peak err {:.2e}, impulse err {:.2e}",
                rel(d, tau),
                rel(p, peak),
                rel(j, 2.0 * m * v)
            );
            assert!(rel(d, tau) < 0.01, "duration {d} vs {tau}");
            assert!(rel(p, peak) < 0.01, "peak {p} vs {peak}");
            // e = 1: impulse = m·v·(1+e).
            assert!(rel(j, 2.0 * m * v) < 1e-4, "impulse {j}");
        }
    }
}

/// Fine f64 reference of the Hunt–Crossley contact in physical units (independent of the
/// dimensionless integrator in force.rs): RK4 with `steps` steps per lossless contact time.
/// Returns (duration s, peak force N, outgoing speed m/s).
fn reference_hc(m: f64, v0: f64, k_alpha: f64, alpha: f64, mu: f64, steps: usize) -> (f64, f64, f64) {
    let force = |x: f64, v: f64| {
        if x > 0.0 {
            (k_alpha * x.powf(alpha) * (1.0 + mu * v)).max(0.0)
        } else {
            0.0
        }
    };
    let acc = |x: f64, v: f64| -force(x, v) / m;
    let xmax = ((alpha + 1.0) * m * v0 * v0 / (2.0 * k_alpha)).powf(1.0 / (alpha + 1.0));
    let h = 3.0 * xmax / v0 / steps as f64;
    let (mut x, mut v, mut t, mut peak) = (0.0f64, v0, 0.0f64, 0.0f64);
    loop {
        let (k1x, k1v) = (v, acc(x, v));
        let (k2x, k2v) = (v + 0.5 * h * k1v, acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
        let (k3x, k3v) = (v + 0.5 * h * k2v, acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
        let (k4x, k4v) = (v + h * k3v, acc(x + h * k3x, v + h * k3v));
        let x1 = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let v1 = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        if x1 <= 0.0 && v1 < 0.0 {
            t += h * x / (x - x1);
            return (t, peak, -v1);
        }
        x = x1;
        v = v1;
        t += h;
        peak = peak.max(force(x, v));
        assert!(t < 1e3 * h * steps as f64, "reference contact never ends");
    }
}

#[test]
fn hunt_crossley_matches_fine_reference() {
    let alpha = HC_DEFAULT_EXPONENT;
    let mu = HC_DEFAULT_DAMPING_S_PER_M;
    for (m, v, k) in [
        (0.05, 1.0, 1e6),
        (0.5, 5.0, 2e5),
        (0.01, 0.3, 1e7),
        (0.05, 20.0, 1e6),
    ] {
        let ka = hunt_crossley_stiffness(k, alpha);
        let (d_ref, p_ref, vout) = reference_hc(m, v, ka, alpha, mu, 200_000);
        let j_ref = m * (v + vout);
        // Oversampled path measured from the signal at 10 MHz, and the summary at 48 kHz.
        let sr = 1.0e7;
        let p = ImpactParams::new(m, v, k, ContactModel::HuntCrossley);
        let (_, out) = render_force(&p, sr);
        let (d, pk) = measure(&out, sr);
        let j: f64 = out.iter().sum();
        let (f48, out48) = render_force(&p, 48_000.0);
        let s = f48.summary();
        let j48: f64 = out48.iter().sum();
        println!(
            "HC m={m} v={v} k={k}: e={:.4}, signal duration err {:.2e}, peak err {:.2e}, impulse err {:.2e}; \
             48k summary duration err {:.2e}, peak err {:.2e}, impulse err {:.2e}",
            vout / v,
            rel(d, d_ref),
            rel(pk, p_ref),
            rel(j, j_ref),
            rel(s.duration_s, d_ref),
            rel(s.peak_force_n, p_ref),
            rel(j48, j_ref)
        );
        assert!(rel(d, d_ref) < 0.01 && rel(pk, p_ref) < 0.01 && rel(j, j_ref) < 0.01);
        assert!(rel(s.duration_s, d_ref) < 0.01 && rel(s.peak_force_n, p_ref) < 0.01);
        assert!(rel(j48, j_ref) < 0.01, "impulse must be m·v·(1+e)");
        assert!(rel(s.restitution, vout / v) < 0.01);
    }
}

#[test]
fn sub_sample_hunt_crossley_contact_delivers_reference_impulse() {
    // A 1 mg striker on a very stiff contact: the contact lasts a small fraction of a sample at
    // 22.05–192 kHz and is delivered whole in one sample.
    let (m, v, k) = (1e-6, 2.0, 1e11);
    let ka = hunt_crossley_stiffness(k, HC_DEFAULT_EXPONENT);
    let (d_ref, p_ref, vout) =
        reference_hc(m, v, ka, HC_DEFAULT_EXPONENT, HC_DEFAULT_DAMPING_S_PER_M, 200_000);
    for sr in [22_050.0, 48_000.0, 192_000.0] {
        let p = ImpactParams::new(m, v, k, ContactModel::HuntCrossley);
        let (f, out) = render_force(&p, sr);
        assert!(d_ref < 0.25 / sr, "test premise: sub-sample contact ({d_ref} s)");
        assert_eq!(out.iter().filter(|&&x| x != 0.0).count(), 1);
        let j: f64 = out.iter().sum();
        let s = f.summary();
        println!(
            "HC sub-sample sr={sr}: duration {d_ref:.3e} s, impulse err {:.2e}, duration err {:.2e}, peak err {:.2e}",
            rel(j, m * (v + vout)),
            rel(s.duration_s, d_ref),
            rel(s.peak_force_n, p_ref)
        );
        assert!(rel(j, m * (v + vout)) < 0.01);
        assert!(rel(s.duration_s, d_ref) < 0.01 && rel(s.peak_force_n, p_ref) < 0.01);
    }
}

#[test]
fn hertz_contact_time_scales_as_v_to_minus_one_fifth() {
    let mut p = ImpactParams::new(0.05, 0.5, 1e6, ContactModel::HuntCrossley);
    p.hc_damping_s_per_m = 0.0;
    let mut f = ImpactForce::default();
    let mut taus = Vec::new();
    for v in [0.1, 1.0, 10.0] {
        p.velocity_m_per_s = v;
        f.start(&p, 48_000.0);
        taus.push(f.duration_s());
    }
    for w in taus.windows(2) {
        let slope = (w[1] / w[0]).log10(); // one decade of velocity
        println!("HC lossless contact-time slope per decade of v: {slope:.5}");
        assert!((slope + 0.2).abs() < 0.002, "slope {slope}");
    }
    // Mass scaling (m/k)^(1/(α+1)) = m^0.4.
    p.velocity_m_per_s = 1.0;
    f.start(&p, 48_000.0);
    let t1 = f.duration_s();
    p.mass_kg = 0.5;
    f.start(&p, 48_000.0);
    let slope = (f.duration_s() / t1).log10();
    assert!((slope - 0.4).abs() < 0.002, "mass slope {slope}");
}

#[test]
fn extreme_contact_inputs_are_finite() {
    for model in [
        ContactModel::Spring,
        ContactModel::RaisedCosine,
        ContactModel::HuntCrossley,
    ] {
        for m in [1e-6, 1e-3, 1.0, 1e3] {
            for v in [0.0, 1e-7, 1e-3, 1.0, 100.0] {
                for k in [20.0, 1e6, 1e11] {
                    for sr in [22_050.0, 192_000.0] {
                        let mut f = ImpactForce::default();
                        f.start(&ImpactParams::new(m, v, k, model), sr);
                        let mut buf = vec![0f32; 8192];
                        // Only the first 64 blocks: long contacts are fine, they just must not blow up.
                        let mut j = 0.0f64;
                        for _ in 0..64 {
                            if !f.is_active() {
                                break;
                            }
                            f.fill(&mut buf);
                            assert!(buf.iter().all(|x| x.is_finite()), "{model:?} m={m} v={v} k={k}");
                            j += buf.iter().map(|&x| x as f64).sum::<f64>();
                        }
                        assert!(j.is_finite() && j >= 0.0 && j <= 2.0 * m * v * 1.0001 + 1e-30);
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Object sampling

#[test]
fn gaussian_draws_match_mean_and_covariance() {
    let presets = builtin_presets();
    let mut rng = EngineRng::seed_from_u64(7);
    let mut out = Vec::with_capacity(1024);
    for p in presets.iter().take(3) {
        let ModeModel::Distribution(d) = &p.modes else {
            continue;
        };
        let mean = &d.gaussian.mean;
        let cov = &d.gaussian.covariance;
        let l = cholesky(cov).unwrap();
        let n = mean.len();
        let draws = 4000;
        let mut sum = vec![0.0; n];
        let mut sq = vec![vec![0.0; n]; n];
        for _ in 0..draws {
            draw(mean, &l, &mut rng, &mut out);
            for i in 0..n {
                let di = out[i] - mean[i];
                sum[i] += di;
                for j in 0..=i {
                    sq[i][j] += di * (out[j] - mean[j]);
                }
            }
        }
        let nd = draws as f64;
        let (mut worst_mean, mut worst_cov) = (0.0f64, 0.0f64);
        for i in 0..n {
            // Mean within 5 standard errors.
            let se = (cov[i][i] / nd).sqrt();
            let z = (sum[i] / nd).abs() / se.max(1e-300);
            worst_mean = worst_mean.max(z);
            for j in 0..=i {
                // Sample covariance SE ≈ √((σ_ii σ_jj + σ_ij²)/N).
                let se = ((cov[i][i] * cov[j][j] + cov[i][j] * cov[i][j]) / nd).sqrt();
                let z = (sq[i][j] / nd - cov[i][j]).abs() / se.max(1e-300);
                worst_cov = worst_cov.max(z);
            }
        }
        println!(
            "{}: worst mean z {worst_mean:.2}, worst covariance z {worst_cov:.2} ({n} dims)",
            p.name
        );
        // Max over n (≈ 50–100) means and n²/2 covariances: 5.5 SE keeps false alarms < 1e-4.
        assert!(worst_mean < 5.5 && worst_cov < 5.5, "{}", p.name);
    }
}

#[test]
fn rejection_sampling_keeps_spacing_within_ten_percent() {
    for mut p in tactus::engine::materials::shipped_presets() {
        // The spacing target is that of the distribution's modes. A dense field's modes are
        // drawn after them on the same stream, so the object without its field holds exactly
        // the modes the rejection sampling kept.
        p.dense = None;
        for f in &mut p.families {
            f.dense = None;
        }
        // A mixture's object keeps its own family's spacing (the nearest of them).
        let targets: Vec<f64> = std::iter::once(&p.modes)
            .filter(|_| p.families.is_empty())
            .chain(p.families.iter().map(|f| &f.modes))
            .filter_map(|m| match m {
                ModeModel::Distribution(d) => Some(d.mean_spacing_octaves),
                ModeModel::Fixed { .. } => None,
            })
            .collect();
        if targets.is_empty() {
            continue;
        }
        let mut s = ObjectSampler::new(&p);
        let mut obj = SampledObject::with_capacity();
        let mut rng = EngineRng::seed_from_u64(11);
        let draws = 100;
        let mut within = 0;
        let mut mean_err = 0.0;
        for _ in 0..draws {
            s.sample(&mut rng, &mut obj);
            let got = obj.mean_spacing_octaves();
            let e = targets
                .iter()
                .map(|t| (got - t) / t)
                .min_by(|a, b| a.abs().total_cmp(&b.abs()))
                .unwrap_or(0.0);
            mean_err += e / draws as f64;
            if e.abs() <= 0.10 {
                within += 1;
            }
            assert!(obj.modes.windows(2).all(|w| w[0].freq_hz <= w[1].freq_hz));
            assert!(obj
                .modes
                .iter()
                .all(|m| m.freq_hz.is_finite() && m.level_db.is_finite()));
        }
        println!(
            "{}: {within}/{draws} within 10 %, mean spacing error {:+.3}",
            p.name, mean_err
        );
        assert!(within >= 95, "{}: only {within}/{draws} within tolerance", p.name);
        assert!(mean_err.abs() < 0.10);
    }
}

#[test]
fn per_hit_variation_has_requested_power_sd() {
    let p = &builtin_presets()[0];
    let mut s = ObjectSampler::new(p);
    let mut obj = SampledObject::with_capacity();
    let mut rng = EngineRng::seed_from_u64(3);
    s.sample(&mut rng, &mut obj);
    let n = obj.modes.len();
    let powers: Vec<f64> = obj.modes.iter().map(|m| 10f64.powf(m.level_db / 10.0)).collect();
    let mean_power = powers.iter().sum::<f64>() / n as f64;
    for variation in [0.05, 0.2] {
        let sd_want = variation * mean_power;
        let draws = 4000;
        let mut levels = vec![0.0; n];
        let mut acc = vec![(0.0, 0.0); n];
        for _ in 0..draws {
            perturb_levels(&obj.modes, variation, &mut rng, &mut levels);
            for (a, &l) in acc.iter_mut().zip(&levels) {
                let q = 10f64.powf(l / 10.0);
                a.0 += q;
                a.1 += q * q;
            }
        }
        // Only modes well above the non-negativity floor (power > 4 SD) are unclipped.
        let mut checked = 0;
        for (i, a) in acc.iter().enumerate() {
            if powers[i] < 4.0 * sd_want {
                continue;
            }
            let m = a.0 / draws as f64;
            let sd = (a.1 / draws as f64 - m * m).max(0.0).sqrt();
            // SE of an SD estimate ≈ SD/√(2N) ≈ 1.1 %; 6 % ≈ 5 SE.
            assert!(rel(sd, sd_want) < 0.06, "mode {i}: sd {sd} vs {sd_want}");
            assert!((m - powers[i]).abs() < 5.0 * sd_want / (draws as f64).sqrt());
            checked += 1;
        }
        println!("variation {variation}: {checked}/{n} modes checked");
        assert!(checked > 0);
    }
}

// ---------------------------------------------------------------------------------------------
/// Every drawn object of a distribution preset has its mean object's peak amplitude sum (each
/// mode counted at the top of its envelope; of a mixture, the family-weighted mean of its
/// families' sums), and its
/// transient the same energy relative to its modes, while the relative mode levels still vary
/// between draws (docs/model.md, "Loudness of a drawn object").
#[test]
fn drawn_objects_are_levelled_to_the_mean_object() {
    for p in builtin_presets().into_iter().chain(family_presets()) {
        // A mixture levels every object to one sum: the family-weighted mean of its families'
        // mean objects' sums (their recordings' gains are as arbitrary as one object's).
        let parts: Vec<(&ModeModel, Option<&DampingModel>, f64)> = if p.families.is_empty() {
            vec![(&p.modes, p.damping.as_ref(), 1.0)]
        } else {
            p.families
                .iter()
                .map(|f| (&f.modes, f.damping.as_ref(), f.weight))
                .collect()
        };
        let sums: Vec<(f64, f64)> = parts
            .iter()
            .filter_map(|(m, law, w)| match m {
                ModeModel::Distribution(d) => Some((peak_amplitude_sum_db(&mean_object_modes(d, *law)), *w)),
                ModeModel::Fixed { .. } => None,
            })
            .collect();
        let weight: f64 = sums.iter().map(|s| s.1).sum();
        let references: Vec<f64> = if sums.is_empty() {
            Vec::new()
        } else {
            vec![sums.iter().map(|(r, w)| r * w).sum::<f64>() / weight]
        };
        if references.is_empty() {
            continue;
        }
        let mut s = ObjectSampler::new(&p);
        let mut obj = SampledObject::with_capacity();
        let mut rng = EngineRng::seed_from_u64(11);
        let (mut ratios, mut spreads) = (Vec::new(), Vec::new());
        for _ in 0..50 {
            s.sample(&mut rng, &mut obj);
            let peak_sum = peak_amplitude_sum_db(&obj.modes);
            assert!(
                references
                    .iter()
                    .any(|r| (peak_sum - r).abs() < 1e-9 * r.abs().max(1.0)),
                "{}: peak sum {peak_sum} vs {references:?}",
                p.name
            );
            let sum = amplitude_sum_db(obj.modes.iter().map(|m| m.level_db));
            if !obj.bands.is_empty() {
                let e = transient_energy_db(obj.bands.iter().map(|b| (b.level_db, b.decay_db_per_s)));
                ratios.push(e - sum);
            }
            let top = obj
                .modes
                .iter()
                .map(|m| m.level_db)
                .fold(f64::NEG_INFINITY, f64::max);
            spreads.push(top - sum);
        }
        let (lo, hi) = span(&ratios);
        assert!(
            ratios.is_empty() || hi - lo < 1e-9 || !p.families.is_empty(),
            "{}: transient ratio {lo}..{hi}",
            p.name
        );
        // The timbre is still drawn: the strongest mode's share of the sum differs between draws.
        let (lo, hi) = span(&spreads);
        println!(
            "{}: amplitude sum {references:.1?} dB, strongest mode {lo:.1}…{hi:.1} dB re the sum",
            p.name
        );
        assert!(hi - lo > 0.5, "{}: relative levels no longer vary", p.name);
    }
}

/// Levelling counts a mode at the top of its envelope, not at its onset level: of two modes
/// drawn as loud as each other at random, one swelling over 30 ms and dying at 600 dB/s (its
/// envelope peaks 17 dB under its onset level) and one ringing from the strike, whichever
/// dominates a draw, default hits play about equally loud (docs/model.md, "Loudness of a drawn
/// object").
#[test]
fn objects_whose_modes_build_up_are_levelled_by_their_envelope_peaks() {
    use tactus::preset::*;
    let mean = vec![-6.0, -6.0, 600f64.ln(), 60f64.ln(), 300f64.log2(), 2000f64.log2()];
    let g = diagonal(mean, &[6.0, 6.0, 0.05, 0.05, 0.01, 0.01]);
    let mut p = builtin_presets().remove(0);
    p.families.clear();
    p.transient = None;
    p.modes = ModeModel::Distribution(ModeDistribution {
        count: 2,
        gaussian: g,
        mean_spacing_octaves: 0.0,
        spacing_tolerance: 0.1,
        decay: DecayCoordinates::Absolute,
        rise_s: vec![0.03, 0.0],
        rings: Vec::new(),
    });
    p.validate().expect("test preset validates");
    let peaks_db = sorted_peaks_db(&hit_peaks_db(&p, 60), 60);
    let (p10, p90) = (peaks_db[6], peaks_db[53]);
    println!("build-up object: default-hit peak p10 {p10:.1}, p90 {p90:.1} dBFS");
    assert!(p90 - p10 < 6.0, "default hits spread over {:.1} dB", p90 - p10);
}

/// Objects per preset whose default hits are rendered for the level tests below.
const DEFAULT_HIT_OBJECTS: u64 = 60;

/// Per built-in and family preset, the peak (dBFS) of one default 1 m/s hit on each of the
/// objects of seeds `0..DEFAULT_HIT_OBJECTS`, in seed order (48 kHz, 0.25 s, 512-sample blocks).
/// Rendered once, in parallel over the presets, for both tests that read them: they ask for the
/// same renders (one test the first 30 seeds of the fitted presets, the other all 60 of every
/// preset), and renders are deterministic.
fn default_hit_peaks() -> &'static [(tactus::preset::Preset, Vec<f64>)] {
    use rayon::prelude::*;
    static PEAKS: std::sync::OnceLock<Vec<(tactus::preset::Preset, Vec<f64>)>> = std::sync::OnceLock::new();
    PEAKS.get_or_init(|| {
        let presets: Vec<_> = builtin_presets().into_iter().chain(family_presets()).collect();
        presets
            .into_par_iter()
            .map(|p| {
                let peaks_db = hit_peaks_db(&p, DEFAULT_HIT_OBJECTS);
                (p, peaks_db)
            })
            .collect()
    })
}

/// Peaks (dBFS, in seed order) of one default 1 m/s hit on each of the objects of seeds
/// `0..objects` of `p` (48 kHz, 0.25 s, 512-sample blocks).
fn hit_peaks_db(p: &tactus::preset::Preset, objects: u64) -> Vec<f64> {
    (0..objects)
        .map(|seed| {
            let (_, l, r) = render_one_hit(p, seed, &Settings::default(), 48_000.0, 0.25, 512);
            20.0 * f64::from(l.iter().chain(&r).fold(0f32, |m, v| m.max(v.abs()))).log10()
        })
        .collect()
}

/// The first `objects` of `peaks_db` (seed order), ascending.
fn sorted_peaks_db(peaks_db: &[f64], objects: usize) -> Vec<f64> {
    let mut v = peaks_db[..objects].to_vec();
    v.sort_by(f64::total_cmp);
    v
}

/// (smallest, largest) of `v`; (+∞, −∞) when empty.
fn span(v: &[f64]) -> (f64, f64) {
    v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &r| {
        (a.0.min(r), a.1.max(r))
    })
}

/// The loudest default MIDI hit (1 m/s, default striker and gain) of 60 objects of every built-in
/// material and family preset stays below full scale, and objects of one material are within 15 dB of each other
/// (10th–90th percentile of peaks). Unlevelled, metal hits peak at up to +20 dBFS and spread
/// over 22 dB.
#[test]
fn default_hits_of_every_preset_stay_below_full_scale() {
    for (p, peaks) in default_hit_peaks() {
        let peaks_db = sorted_peaks_db(peaks, 60);
        let (p10, p90, max) = (peaks_db[6], peaks_db[53], peaks_db[59]);
        println!(
            "{}: default-hit peak p10 {p10:.1}, p90 {p90:.1}, max {max:.1} dBFS",
            p.name
        );
        assert!(max < 0.0, "{}: a default hit peaks at {max:.1} dBFS", p.name);
        assert!(
            p10 > -60.0,
            "{}: default hits nearly silent ({p10:.1} dBFS)",
            p.name
        );
        assert!(
            p90 - p10 < 15.0,
            "{}: peaks spread over {:.1} dB",
            p.name,
            p90 - p10
        );
    }
}

/// Switching between fitted presets does not drop the level by tens of dB: every fitted preset's
/// median default-hit peak lies within 12 dB of the median over them. Fits normalised by their
/// strongest mode's onset level would put Steel Pan, whose strongest modes build up, ~20 dB under
/// the rest (docs/model.md, "Loudness of a drawn object").
#[test]
fn fitted_presets_play_default_hits_at_comparable_levels() {
    use tactus::preset::Origin;
    let mut medians = Vec::new();
    for (p, peaks) in default_hit_peaks()
        .iter()
        .filter(|(p, _)| p.origin == Origin::Fitted)
    {
        let peaks_db = sorted_peaks_db(peaks, 30);
        medians.push((p.name.clone(), peaks_db[15]));
    }
    let mut all: Vec<f64> = medians.iter().map(|m| m.1).collect();
    all.sort_by(f64::total_cmp);
    let centre = all[all.len() / 2];
    println!("median default-hit peaks (dBFS), centre {centre:.1}: {medians:.1?}");
    assert!(medians.len() >= 8, "fitted presets: {medians:?}");
    for (name, m) in &medians {
        assert!(
            (m - centre).abs() < 12.0,
            "{name}: {m:.1} dBFS against {centre:.1}"
        );
    }
}

/// A Gaussian with independent coordinates: `mean` and per-coordinate SDs.
fn diagonal(mean: Vec<f64>, sd: &[f64]) -> tactus::preset::Gaussian {
    let n = mean.len();
    let mut covariance = vec![vec![0.0; n]; n];
    for i in 0..n {
        covariance[i][i] = sd[i] * sd[i];
    }
    tactus::preset::Gaussian { mean, covariance }
}

/// A distribution of `m` modes log-spaced from 200 Hz to 6.4 kHz, with a shared log-frequency
/// factor of 0.5 octave SD (objects of different sizes), all `ln b` coordinates 0 ± 0.1.
fn law_preset(decay: tactus::preset::DecayCoordinates) -> tactus::preset::Preset {
    use tactus::preset::*;
    let m = 6;
    let mut mean = vec![-12.0; 3 * m];
    for i in 0..m {
        mean[m + i] = if decay == DecayCoordinates::Absolute {
            3.0
        } else {
            0.0
        };
        mean[2 * m + i] = 200f64.log2() + i as f64;
    }
    let mut g = diagonal(mean, &[[2.0; 6], [0.1; 6], [0.02; 6]].concat());
    for i in 0..m {
        for j in 0..m {
            g.covariance[2 * m + i][2 * m + j] += 0.25;
        }
    }
    let mut p = builtin_presets().remove(0);
    p.families.clear();
    p.transient = None;
    p.modes = ModeModel::Distribution(ModeDistribution {
        count: m,
        gaussian: g,
        mean_spacing_octaves: 1.0,
        spacing_tolerance: 0.1,
        decay,
        rise_s: Vec::new(),
        rings: Vec::new(),
    });
    // Rayleigh: c = 2 + 1e-8·ω² 1/s, 9 dB/s at 200 Hz, 79 dB/s at 6.4 kHz (slope ≈ 0.6).
    p.damping = Some(DampingModel {
        alpha1: 2.0,
        alpha2: 1e-8,
        alpha3: 1.0,
        sigma: 0.0,
        eta: 0.0,
    });
    p.validate().expect("test preset validates");
    p
}

/// Least-squares slope of ln(decay) against ln(frequency) over one object's modes.
fn decay_slope(obj: &SampledObject) -> f64 {
    let pts: Vec<(f64, f64)> = obj
        .modes
        .iter()
        .map(|m| (m.freq_hz.ln(), m.decay_db_per_s.ln()))
        .collect();
    common::line_slope(&pts)
}

/// Decays stored relative to the damping law follow the law at the *drawn* frequency: an
/// object drawn an octave higher decays as the law says there, and within an object the decay
/// grows with frequency as the law's does; absolute decays do neither.
#[test]
fn drawn_decays_follow_the_damping_law_at_the_drawn_frequency() {
    use tactus::preset::DecayCoordinates;
    for (decay, slope_range) in [
        (DecayCoordinates::DampingResidual, (0.3, 1.6)),
        (DecayCoordinates::Absolute, (-0.1, 0.1)),
    ] {
        let p = law_preset(decay);
        let law = p.damping.unwrap();
        let mut s = ObjectSampler::new(&p);
        let mut obj = SampledObject::with_capacity();
        let mut rng = EngineRng::seed_from_u64(5);
        let (mut slopes, mut worst) = (Vec::new(), 0.0f64);
        for _ in 0..200 {
            s.sample(&mut rng, &mut obj);
            slopes.push(decay_slope(&obj));
            if decay == DecayCoordinates::DampingResidual {
                for m in &obj.modes {
                    // Residual SD 0.1: the decay is the law's within ±0.5 (5 SD) in ln.
                    worst = worst.max((m.decay_db_per_s / law.decay_db_per_s(m.freq_hz)).ln().abs());
                }
            }
        }
        slopes.sort_by(f64::total_cmp);
        let median = slopes[slopes.len() / 2];
        println!("{decay:?}: median ln-decay slope {median:.2}, worst |ln(b/law)| {worst:.2}");
        assert!(
            median > slope_range.0 && median < slope_range.1,
            "{decay:?}: median slope {median:.2} outside {slope_range:?}"
        );
        assert!(worst < 0.5, "{decay:?}: a decay is {worst:.2} (ln) off the law");
    }
}

/// A mixture preset draws each family with probability proportional to its weight, every
/// object wholly from one family, reproducibly for a seed.
#[test]
fn mixture_draws_pick_families_by_weight() {
    use tactus::preset::*;
    let fixed = |f: f64| ModeModel::Fixed {
        modes: vec![
            FixedMode {
                freq_hz: f,
                level_db: -10.0,
                decay_db_per_s: 20.0,
                rise_s: 0.0,
                ring: Default::default(),
            },
            FixedMode {
                freq_hz: 2.0 * f,
                level_db: -16.0,
                decay_db_per_s: 30.0,
                rise_s: 0.0,
                ring: Default::default(),
            },
        ],
    };
    let mut p = builtin_presets().remove(0);
    p.families = vec![
        Family {
            name: "low".into(),
            weight: 1.0,
            modes: fixed(200.0),
            transient: None,
            damping: None,
            dense: None,
            size_class: None,
        },
        Family {
            name: "high".into(),
            weight: 3.0,
            modes: fixed(3000.0),
            transient: p.transient.clone(),
            damping: None,
            dense: None,
            size_class: None,
        },
    ];
    p.validate().expect("mixture validates");
    let back = Preset::from_json(&p.to_json(), None).expect("mixture round-trips");
    assert_eq!(back, p);
    let mut s = ObjectSampler::new(&p);
    let mut obj = SampledObject::with_capacity();
    let mut rng = EngineRng::seed_from_u64(3);
    let draws = 2000;
    let mut high = 0;
    for _ in 0..draws {
        s.sample(&mut rng, &mut obj);
        let f0 = obj.modes[0].freq_hz;
        assert!(f0 == 200.0 || f0 == 3000.0, "mode {f0} Hz of no family");
        assert_eq!(obj.modes[1].freq_hz, 2.0 * f0, "object mixes families");
        if f0 == 3000.0 {
            high += 1;
            assert!(!obj.bands.is_empty(), "the high family's transient is missing");
        } else {
            assert!(obj.bands.is_empty(), "the low family has no transient");
        }
    }
    let share = high as f64 / draws as f64;
    println!("high family drawn {high}/{draws}");
    // Binomial SD at p = 0.75, N = 2000: 0.0097; 4 SD.
    assert!(
        (share - 0.75).abs() < 0.04,
        "high family share {share:.3}, want 0.75"
    );
}
