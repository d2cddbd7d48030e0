//! Cost per sample of the sustained-contact force generators, alone and driving a 64-mode bank.
//! `cargo bench --bench sustained`

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use tactus::engine::materials::builtin_presets;
use tactus::engine::modal::{ModalBank, ModeParams};
use tactus::engine::sustained::{ContactKind, MotionKind, SustainedParams, SustainedVoice};
use tactus::engine::{Engine, Settings};

const FS: f64 = 48_000.0;
const BLOCK: usize = 512;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("sustained");
    g.throughput(Throughput::Elements(BLOCK as u64));
    let cases = [
        (
            "scrape_manual",
            SustainedParams {
                motion: MotionKind::Manual,
                scrape_speed_m_per_s: 0.5,
                ..Default::default()
            },
        ),
        (
            "scrape_circular_2d",
            SustainedParams {
                motion: MotionKind::Circular,
                scrape_speed_m_per_s: 0.5,
                ..Default::default()
            },
        ),
        (
            "roll",
            SustainedParams {
                kind: ContactKind::Roll,
                ..Default::default()
            },
        ),
    ];
    for (name, p) in cases {
        let mut v = SustainedVoice::new(FS, 1);
        let mut buf = [0.0f32; BLOCK];
        g.bench_function(name, |b| {
            b.iter(|| {
                v.process(black_box(&p), None, &mut buf);
                black_box(&buf);
            })
        });
    }
    let modes: Vec<ModeParams> = (0..64)
        .map(|i| ModeParams {
            freq_hz: 200.0 * (1.0 + i as f64 * 0.37),
            decay_db_per_s: 30.0,
            gain: 1.0,
        })
        .collect();
    let mut bank = ModalBank::with_capacity(64);
    bank.set_sample_rate(FS);
    bank.set_modes(&modes);
    let p = SustainedParams {
        motion: MotionKind::Manual,
        scrape_speed_m_per_s: 0.5,
        ..Default::default()
    };
    let mut v = SustainedVoice::new(FS, 1);
    let mut buf = [0.0f32; BLOCK];
    let mut out = [0.0f32; BLOCK];
    g.bench_function("scrape_manual_plus_64_mode_bank", |b| {
        b.iter(|| {
            v.process(&p, None, &mut buf);
            out.iter_mut().for_each(|x| *x = 0.0);
            bank.process(Some(&buf), &mut out);
            black_box(&out);
        })
    });
    // The whole engine path: scrape channel (force + its bank with the object's modes, morphing
    // and striker IR), as the plugin runs it.
    let mut e = Engine::new(&builtin_presets()[1], 8, 1);
    e.prepare(FS, BLOCK);
    let s = Settings {
        scrape: tactus::engine::ScrapeParams {
            speed_m_per_s: 0.5,
            pressure_n: 5.0,
            ..Default::default()
        },
        ..Settings::default()
    };
    let (mut l, mut r) = ([0.0f32; BLOCK], [0.0f32; BLOCK]);
    g.bench_function("engine_scrape", |b| {
        b.iter(|| {
            e.process(black_box(&s), &[], &mut l, &mut r);
            black_box(&l);
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
