//! The engine's handling of impacts: seeded determinism across block sizes, loudness and
//! brightness against velocity and striker mass, robustness under abuse, the voice cap, stealing
//! and sleeping, perceptual culling (docs/model.md §8: the work it saves and the spectrum it
//! keeps), the force meter and re-strike merging.

use crate::common;
use tactus::engine::force::{ContactModel, ImpactForce, ImpactParams};
use tactus::engine::materials::builtin_presets;
use tactus::engine::{Engine, EngineOptions, Event, Settings};

/// Least share (%) of the unculled scene's mode-samples that culling at the default quality
/// skips in `culling_and_sleeping_savings` (measured: 85.0 %; the margin leaves room for a
/// more careful rule, not for culling that does nothing).
const CULLING_SAVES_PERCENT: f64 = 70.0;

/// Least share (%) of the never-sleeping bound that sleeping (culling off) skips in
/// `culling_and_sleeping_savings` (measured: 79.2 %).
const SLEEPING_SAVES_PERCENT: f64 = 60.0;

/// Renders `total` samples with block size `block`, hits at the given (sample, velocity) times.
fn render_engine(
    settings: &Settings,
    hits: &[(usize, f64)],
    total: usize,
    block: usize,
    seed: u64,
    sr: f64,
) -> Vec<f32> {
    let presets = builtin_presets();
    let mut e = Engine::new(&presets[0], 8, seed);
    e.prepare(sr, block);
    let mut out = vec![0f32; total];
    let mut right = vec![0f32; block];
    let mut pos = 0;
    while pos < total {
        let n = block.min(total - pos);
        let events = block_hits(hits, pos, n);
        e.process(settings, &events, &mut out[pos..pos + n], &mut right[..n]);
        pos += n;
    }
    out
}

/// The impacts among `hits` (sample time, velocity) that fall in the block `pos..pos + n`, at
/// their offsets in it (pitch factor 1, no key).
fn block_hits(hits: &[(usize, f64)], pos: usize, n: usize) -> Vec<Event> {
    hits.iter()
        .filter(|&&(t, _)| t >= pos && t < pos + n)
        .map(|&(t, v)| Event::Impact {
            offset: (t - pos) as u32,
            velocity_m_per_s: v,
            pitch_factor: 1.0,
            key: -1,
        })
        .collect()
}

fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|&v| (v as f64).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
}

#[test]
fn seeded_determinism_across_block_sizes() {
    let s = Settings::default();
    let hits = [(0, 1.0), (1000, 0.5), (5003, 2.0), (9000, 0.3)];
    let total = 24_000;
    let a = render_engine(&s, &hits, total, 512, 42, 48_000.0);
    let b = render_engine(&s, &hits, total, 512, 42, 48_000.0);
    assert_eq!(a, b, "same seed, same block size must be bit-identical");
    let c = render_engine(&s, &hits, total, 512, 43, 48_000.0);
    assert!(a != c, "a different seed must change the sound");
    let peak = a.iter().fold(0f32, |m, v| m.max(v.abs()));
    for block in [1, 64, 4096] {
        let d = render_engine(&s, &hits, total, block, 42, 48_000.0);
        let diff = a.iter().zip(&d).fold(0f32, |m, (x, y)| m.max((x - y).abs()));
        println!("block {block}: max |diff| vs block 512 = {diff:e} (peak {peak})");
        // Block boundaries only move when decayed bands/voices are dropped (below −110 dBFS).
        assert!(diff <= 1e-5 * peak.max(1.0), "block {block}: diff {diff}");
    }
}

#[test]
fn higher_velocity_is_louder() {
    let s = Settings::default();
    let mut last = 0.0;
    for v in [0.1, 0.5, 2.0, 8.0] {
        let r = rms(&render_engine(&s, &[(0, v)], 9_600, 512, 5, 48_000.0));
        assert!(r > last * 1.5, "v={v}: rms {r} vs {last}");
        last = r;
    }
}

/// Spectral centroid (Hz) of `x` via a Hann-windowed real FFT.
fn centroid_hz(x: &[f32], sr: f64) -> f64 {
    let n = x.len();
    let spec = common::hann_spectrum(x);
    let (mut num, mut den) = (0.0, 0.0);
    for (k, c) in spec.iter().enumerate() {
        let p = c.norm_sqr();
        num += p * k as f64 * sr / n as f64;
        den += p;
    }
    num / den
}

#[test]
fn heavier_striker_longer_contact_darker_sound() {
    for model in [
        ContactModel::Spring,
        ContactModel::RaisedCosine,
        ContactModel::HuntCrossley,
    ] {
        let mut last_tau = 0.0;
        let mut last_centroid = f64::INFINITY;
        for m in [0.005, 0.05, 0.5] {
            let s = Settings {
                impact: tactus::engine::ImpactSettings {
                    mass_kg: m,
                    contact_model: model,
                    variation: 0.0,
                    ..Default::default()
                },
                ..Settings::default()
            };
            let k = builtin_presets()[0].contact_stiffness_n_per_m;
            let mut f = ImpactForce::default();
            f.start(&ImpactParams::new(m, 1.0, k, model), 48_000.0);
            let tau = f.duration_s();
            // Geometric mean over 8 objects: one object can have its strongest mode on a null
            // of the contact spectrum (a 1.57 ms half sine has one at 955 Hz), which makes that
            // object brighter under the heavier striker; the claim is about the sound on average.
            let seeds = 1..=8u64;
            let c = seeds
                .clone()
                .map(|seed| {
                    centroid_hz(
                        &render_engine(&s, &[(0, 1.0)], 8_192, 512, seed, 48_000.0),
                        48_000.0,
                    )
                    .ln()
                })
                .sum::<f64>()
                / seeds.count() as f64;
            let c = c.exp();
            println!(
                "{model:?} m={m}: contact {:.3} ms, centroid {c:.0} Hz (geometric mean of 8 objects)",
                tau * 1e3
            );
            assert!(tau > last_tau && c < last_centroid, "{model:?} m={m}");
            last_tau = tau;
            last_centroid = c;
        }
    }
}

#[test]
fn everything_stays_finite_under_abuse() {
    let hits = [(0, 100.0), (100, 0.0), (200, 1e-9), (300, 37.0)];
    for model in [
        ContactModel::Spring,
        ContactModel::HuntCrossley,
        ContactModel::RaisedCosine,
    ] {
        for mass_kg in [1e-6, 1e3] {
            for (sr, block) in [(22_050.0, 1), (44_100.0, 8192), (192_000.0, 333)] {
                let s = Settings {
                    impact: tactus::engine::ImpactSettings {
                        mass_kg,
                        damping: 0.0,
                        hardness: 1e4,
                        contact_model: model,
                        ..Default::default()
                    },
                    ..Settings::default()
                };
                let out = render_engine(&s, &hits, 12_000, block, 1, sr);
                assert!(out.iter().all(|v| v.is_finite()), "{model:?} m={mass_kg} sr={sr}");
            }
        }
    }
    // NaN everywhere in settings and events.
    let nan = f64::NAN;
    let s = Settings {
        impact: tactus::engine::ImpactSettings {
            size: nan,
            damping: nan,
            mass_kg: nan,
            hardness: nan,
            variation: nan,
            ..Default::default()
        },
        output: tactus::engine::OutputSettings {
            quality_db: nan,
            gain_db: nan,
            width: nan,
        },
        ..Settings::default()
    };
    let mut e = Engine::new(&builtin_presets()[1], 4, 2);
    let (mut l, mut r) = (vec![0f32; 1024], vec![0f32; 1024]);
    let ev = [
        Event::Impact {
            offset: 0,
            velocity_m_per_s: nan,
            pitch_factor: nan,
            key: 0,
        },
        Event::Impact {
            offset: 10,
            velocity_m_per_s: 1.0,
            pitch_factor: nan,
            key: 0,
        },
        Event::Impact {
            offset: 20,
            velocity_m_per_s: f64::INFINITY,
            pitch_factor: f64::INFINITY,
            key: 1,
        },
    ];
    for _ in 0..20 {
        e.process(&s, &ev, &mut l, &mut r);
        assert!(l.iter().chain(&r).all(|v| v.is_finite()));
    }
    assert!(l.iter().any(|&v| v != 0.0), "the valid hit must still sound");
}

#[test]
fn voice_cap_and_sleep() {
    let presets = builtin_presets();
    let mut e = Engine::new(&presets[0], 4, 1);
    e.prepare(48_000.0, 512);
    let s = Settings::default();
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    let ev: Vec<Event> = (0..10)
        .map(|i| Event::Impact {
            offset: i * 10,
            velocity_m_per_s: 1.0,
            pitch_factor: 1.0,
            key: i as i32,
        })
        .collect();
    e.process(&s, &ev, &mut l, &mut r);
    assert_eq!(e.active_voices(), 4, "capped at 4 voices");
    // Everything decays below −110 dBFS and goes to sleep well within 30 s.
    let mut slept_after = None;
    for b in 0..(30 * 48_000 / 512) {
        e.process(&s, &[], &mut l, &mut r);
        if e.active_voices() == 0 {
            slept_after = Some(b);
            break;
        }
    }
    let b = slept_after.expect("voices never slept");
    assert!(l.iter().all(|v| v.abs() < 1e-4));
    println!(
        "all voices asleep after {:.2} s",
        (b + 1) as f64 * 512.0 / 48_000.0
    );
    let before = e.take_stats();
    e.process(&s, &[], &mut l, &mut r);
    assert_eq!(e.take_stats().mode_samples, 0, "sleeping voices cost nothing");
    assert!(before.mode_samples > 0);
}

/// Mode-samples (engine `Stats`, not wall time) of `hits` over `total` samples on the first
/// built-in material, 8 voices, block 512, with culling and re-strike merging as given.
fn scene_mode_samples(
    s: &Settings,
    hits: &[(usize, f64)],
    total: usize,
    culling: bool,
    merging: bool,
) -> u64 {
    let mut e = Engine::new(&builtin_presets()[0], 8, 4);
    e.prepare(48_000.0, 512);
    e.set_options(EngineOptions {
        culling,
        merging,
        ..EngineOptions::default()
    });
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    for b in 0..total / 512 {
        e.process(s, &block_hits(hits, b * 512, 512), &mut l, &mut r);
    }
    e.take_stats().mode_samples
}

/// Culling and sleeping save work, counted in mode-samples: a typical scene (8 hits over 2 s at
/// various speeds, then 2 s of tail), each hit on its own voice (merging off, so only culling
/// and sleeping act). Culling at the default quality must skip at least
/// [`CULLING_SAVES_PERCENT`] of what the same scene computes unculled, and sleeping (culling off)
/// at least [`SLEEPING_SAVES_PERCENT`] of what every voice would compute if it ran to the end
/// with all its modes; a higher `quality` culls less.
#[test]
fn culling_and_sleeping_savings() {
    let hits: Vec<(usize, f64)> = (0..8).map(|i| (i * 12_000, 0.3 + 0.4 * i as f64)).collect();
    let total = 4 * 48_000;
    let default = Settings::default();
    let finest = Settings {
        output: tactus::engine::OutputSettings {
            quality_db: 300.0,
            ..default.output
        },
        ..default
    };
    let culled = scene_mode_samples(&default, &hits, total, true, false);
    let finest_culled = scene_mode_samples(&finest, &hits, total, true, false);
    let unculled = scene_mode_samples(&default, &hits, total, false, false);
    // Resonators of the object the scene strikes (a mode with a build-up runs two); a mixture's
    // objects have their own family's mode count, not the pooled one.
    let count: usize = Engine::new(&builtin_presets()[0], 8, 4)
        .object()
        .modes
        .iter()
        .map(|m| 1 + usize::from(m.rise_s > 0.0))
        .sum();
    // Without sleeping every hit's voice would run to the end of the render with all modes.
    let never_sleep: u64 = hits.iter().map(|h| ((total - h.0) * count) as u64).sum();
    let saved = |a: u64, b: u64| 100.0 * (1.0 - a as f64 / b as f64);
    println!(
        "mode-samples: culled (quality 60) {culled}, culled at quality 300 {finest_culled}, \
         unculled {unculled}, no sleep bound {never_sleep}; culling saves {:.1} %, \
         sleeping {:.1} %, both {:.1} %",
        saved(culled, unculled),
        saved(unculled, never_sleep),
        saved(culled, never_sleep)
    );
    assert!(culled <= finest_culled && finest_culled <= unculled && unculled <= never_sleep);
    assert!(
        saved(culled, unculled) >= CULLING_SAVES_PERCENT,
        "culling saves too little"
    );
    assert!(
        saved(unculled, never_sleep) >= SLEEPING_SAVES_PERCENT,
        "sleeping saves too little"
    );
}

#[test]
fn steals_the_quietest_voice() {
    let presets = builtin_presets();
    let mut e = Engine::new(&presets[0], 2, 1);
    e.prepare(48_000.0, 256);
    let s = Settings::default();
    let (mut l, mut r) = (vec![0f32; 256], vec![0f32; 256]);
    let hit = |key: i32, v: f64| Event::Impact {
        offset: 0,
        velocity_m_per_s: v,
        pitch_factor: 1.0,
        key,
    };
    let choke = |key: i32| Event::Choke { offset: 0, key };
    // Loud key 0 first (oldest), quiet key 1 second; one block so their levels are measured.
    e.process(&s, &[hit(0, 5.0)], &mut l, &mut r);
    e.process(&s, &[hit(1, 0.05)], &mut l, &mut r);
    e.process(&s, &[], &mut l, &mut r);
    // Key 2 must take the quiet voice (key 1), not the older loud one.
    e.process(&s, &[hit(2, 1.0)], &mut l, &mut r);
    assert_eq!(e.active_voices(), 2);
    e.process(&s, &[choke(1)], &mut l, &mut r);
    assert_eq!(
        e.active_voices(),
        2,
        "key 1 was stolen, choking it silences nothing"
    );
    e.process(&s, &[choke(0)], &mut l, &mut r);
    assert_eq!(e.active_voices(), 1, "loud key 0 survived the steal");
    e.process(&s, &[choke(2)], &mut l, &mut r);
    assert_eq!(e.active_voices(), 0);
}

/// The engine's force meter (`take_force_peak_n`, fed to the editor) reports the contact's
/// peak: for a spring impact the analytic `v·√(k·m)` (per-sample means of a half sine a few
/// dozen samples long lie within 1 % of it), nothing when no contact, and it resets when read.
#[test]
fn force_peak_meter_matches_the_spring_peak_and_resets() {
    // The meter, not a material, is under test: a stiffness of its own gives a contact of
    // ~34 samples at 48 kHz, long enough for the sampled peak to be the spring's.
    let mut preset = builtin_presets()[0].clone();
    preset.contact_stiffness_n_per_m = 1.0e6;
    let k = preset.contact_stiffness_n_per_m;
    let mut e = Engine::new(&preset, 8, 3);
    e.prepare(48_000.0, 512);
    let s = Settings {
        impact: tactus::engine::ImpactSettings {
            contact_model: ContactModel::Spring,
            mass_kg: 0.05,
            hardness: 1.0,
            ..Default::default()
        },
        ..Settings::default()
    };
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    e.process(&s, &[], &mut l, &mut r);
    assert_eq!(e.take_force_peak_n(), 0.0, "no contact, no force");
    let hit = [Event::Impact {
        offset: 10,
        velocity_m_per_s: 2.0,
        pitch_factor: 1.0,
        key: -1,
    }];
    e.process(&s, &hit, &mut l, &mut r);
    let peak = e.take_force_peak_n() as f64;
    let expected = 2.0 * (k * 0.05f64).sqrt();
    let tau = std::f64::consts::PI * (0.05 / k).sqrt();
    println!(
        "peak {peak:.2} N vs v·√(k·m) = {expected:.2} N (contact {:.2} ms)",
        tau * 1e3
    );
    assert!(tau * 48_000.0 > 10.0, "the check needs a contact of many samples");
    assert!((peak - expected).abs() < 0.01 * expected, "{peak} vs {expected}");
    assert_eq!(e.take_force_peak_n(), 0.0, "read resets the meter");
}

#[test]
fn dense_scene_culling_keeps_the_spectrum() {
    // 60 glass hits in 1.2 s at varied speeds and pitches on 32 voices: the per-voice floors,
    // the threshold of hearing and masking across voices all retire modes. The culled render
    // must keep the ERB-band spectrum of the unculled one and compute far fewer mode-samples.
    let glass = builtin_presets()
        .into_iter()
        .find(|p| p.material_class == "glass")
        .expect("a glass preset");
    let total = 2 * 48_000;
    let render = |culling: bool| {
        let mut e = Engine::new(&glass, 32, 11);
        e.prepare(48_000.0, 64);
        e.set_culling_enabled(culling);
        let s = Settings::default();
        let (mut l, mut r) = (vec![0f32; 64], vec![0f32; 64]);
        let mut out = Vec::with_capacity(total);
        for b in 0..total / 64 {
            let ev: Vec<Event> = (0..60usize)
                .filter(|i| i * 960 / 64 == b)
                .map(|i| Event::Impact {
                    offset: ((i * 960) % 64) as u32,
                    velocity_m_per_s: 0.3 + 0.035 * ((i * 37) % 60) as f64,
                    pitch_factor: 0.8 + 0.4 * ((i * 23) % 60) as f64 / 60.0,
                    key: -1,
                })
                .collect();
            e.process(&s, &ev, &mut l, &mut r);
            out.extend(l.iter().map(|&x| x as f64));
        }
        (out, e.take_stats().mode_samples)
    };
    let (full, full_ms) = render(false);
    let (culled, culled_ms) = render(true);
    let lsd = tactus::bench::erb_lsd_db(&full, &culled, 48_000.0);
    println!("mode-samples {culled_ms} culled vs {full_ms} unculled, ERB-LSD {lsd:.3} dB");
    assert!(culled.iter().all(|v| v.is_finite()));
    assert!(lsd < 0.1, "culling changed the spectrum by {lsd:.3} dB");
    // Measured 2026-11-23: 12.41 M vs 36.29 M (2.9×) at 0.035 dB (without the masked-power budget
    // 3.9×, but see `chord_culling_keeps_the_spectrum`); 1.8× without masking.
    assert!(
        culled_ms * 5 < full_ms * 2,
        "culling saved too little: {culled_ms} vs {full_ms}"
    );
}

#[test]
fn chord_culling_keeps_the_spectrum() {
    // 32 voices of one 64-mode object a quarter semitone apart, barely damped: hundreds of
    // near-coincident modes, each far below the loudest in its critical band. Each is masked on
    // its own, but their powers add: without the per-critical-band budget of masked power
    // (`Maskers::masks`) culling removed several dB from crowded bands (the 64-voice bench chord
    // measured 0.99 dB ERB-LSD; with it 0.04 dB).
    let object = tactus::bench::preset64();
    let total = 48_000;
    let render = |culling: bool| {
        let mut e = Engine::new(&object, 32, 5);
        e.prepare(48_000.0, 256);
        e.set_culling_enabled(culling);
        let s = Settings {
            impact: tactus::engine::ImpactSettings {
                damping: 0.05,
                ..Default::default()
            },
            ..Settings::default()
        };
        let (mut l, mut r) = (vec![0f32; 256], vec![0f32; 256]);
        let hits: Vec<Event> = (0..32)
            .map(|i| Event::Impact {
                offset: 0,
                velocity_m_per_s: 1.0,
                pitch_factor: 2f64.powf((i as f64 - 16.0) / 48.0),
                key: -1,
            })
            .collect();
        let mut out = Vec::with_capacity(total);
        for b in 0..total / 256 {
            e.process(&s, if b == 0 { &hits } else { &[] }, &mut l, &mut r);
            out.extend(l.iter().map(|&x| x as f64));
        }
        (out, e.take_stats().mode_samples)
    };
    let (full, full_ms) = render(false);
    let (culled, culled_ms) = render(true);
    let lsd = tactus::bench::erb_lsd_db(&full, &culled, 48_000.0);
    println!("chord: mode-samples {culled_ms} culled vs {full_ms} unculled, ERB-LSD {lsd:.3} dB");
    assert!(lsd < 0.1, "culling changed the chord's spectrum by {lsd:.3} dB");
    assert!(culled_ms < full_ms, "culling retired nothing");
}

/// Re-strikes of one ringing object (`Engine::set_merging_enabled`): merged into the ringing
/// voice, the render equals the stacked one (one voice per hit) up to f32 rounding, with fewer
/// mode-samples; hits on another key, during a contact or after a retune still take their own
/// voice.
#[test]
fn restrikes_merge_into_the_ringing_voice() {
    let presets = builtin_presets();
    let metal = &presets[1];
    // A bouncing ball: restitution 0.75 from 2 m/s, flight 2·v/g between impacts.
    let mut hits = Vec::new();
    let (mut t, mut v) = (0.0f64, 2.0f64);
    while v > 0.05 {
        hits.push(((t * 48_000.0) as usize, v));
        v *= 0.75;
        t += 2.0 * v / 9.81;
    }
    let total = 2 * 48_000;
    let render = |merging: bool, culling: bool| {
        let mut e = Engine::new(metal, 16, 3);
        e.prepare(48_000.0, 128);
        e.set_merging_enabled(merging);
        e.set_culling_enabled(culling);
        let s = Settings::default();
        let (mut l, mut r) = (vec![0f32; 128], vec![0f32; 128]);
        let mut out = Vec::with_capacity(total);
        let mut most = 0;
        for b in 0..total / 128 {
            e.process(&s, &block_hits(&hits, b * 128, 128), &mut l, &mut r);
            most = most.max(e.active_voices());
            out.extend(l.iter().map(|&x| x as f64));
        }
        (out, e.take_stats().mode_samples, most)
    };
    let (stacked, stacked_ms, stacked_voices) = render(false, false);
    let (merged, merged_ms, merged_voices) = render(true, false);
    let snr = tactus::engine::reference::snr_db(&stacked, &merged);
    println!(
        "{} hits: stacked {stacked_ms} mode-samples on up to {stacked_voices} voices, merged \
         {merged_ms} on up to {merged_voices}; SNR {snr:.1} dB",
        hits.len()
    );
    assert!(merged.iter().all(|x| x.is_finite()));
    // Not bit-identical: each stacked voice sleeps on its own once its bound falls below
    // −110 dBFS, the merged voice only when the sum does; and f32 rounding.
    assert!(snr > 90.0, "merging changed the sound: SNR {snr:.1} dB");
    // Measured 5.10× on the family-mixture Metal (seed 3); a voice that does not merge saves
    // nothing (1×).
    assert!(merged_ms * 5 < stacked_ms * 2, "merging saved too little");
    // With culling too, against the stacked unculled render.
    let (culled, culled_ms, _) = render(true, true);
    let lsd = tactus::bench::erb_lsd_db(&stacked, &culled, 48_000.0);
    println!("merged + culled: {culled_ms} mode-samples, ERB-LSD {lsd:.3} dB");
    assert!(lsd < 0.5 && culled_ms <= merged_ms);

    // Not merged: another key, a hit during the contact, a retuned object.
    // (Transient off: a merge moves a still-sounding transient to a voice of its own.)
    let mut e = Engine::new(metal, 8, 3);
    e.prepare(48_000.0, 256);
    e.set_transient_enabled(false);
    let mut s = Settings {
        impact: tactus::engine::ImpactSettings {
            variation: 0.0,
            ..Default::default()
        },
        ..Settings::default()
    };
    let (mut l, mut r) = (vec![0f32; 256], vec![0f32; 256]);
    let hit = |key: i32, offset: u32| Event::Impact {
        offset,
        velocity_m_per_s: 1.0,
        pitch_factor: 1.0,
        key,
    };
    e.process(&s, &[hit(0, 0), hit(0, 2)], &mut l, &mut r);
    assert_eq!(
        e.active_voices(),
        2,
        "a hit during the contact takes its own voice"
    );
    e.process(&s, &[hit(1, 0)], &mut l, &mut r);
    assert_eq!(e.active_voices(), 3, "another key takes its own voice");
    // Voices are counted just before and just after each hit, 21 ms after the last one (every
    // contact long over): over a longer wait a short-ringing object's voices fall asleep,
    // and the count would measure sleeping, not merging.
    let settle = |e: &mut Engine, l: &mut [f32], r: &mut [f32]| {
        for _ in 0..4 {
            e.process(&s, &[], l, r);
        }
    };
    settle(&mut e, &mut l, &mut r);
    let before = e.active_voices();
    e.process(&s, &[hit(1, 0)], &mut l, &mut r);
    assert_eq!(e.active_voices(), before, "same key, contact over: merged");
    settle(&mut e, &mut l, &mut r);
    let before = e.active_voices();
    s.impact.size = 1.1;
    e.process(&s, &[hit(1, 0)], &mut l, &mut r);
    assert_eq!(
        e.active_voices(),
        before + 1,
        "a resized object takes its own voice"
    );
}
