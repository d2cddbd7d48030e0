//! Stereo pickups through the engine (docs/model.md "Stereo pickups"): width 0 is mono (identical
//! channels, and the mono engine's render bit for bit on the demo scene); any width leaves the
//! object's and the hits' draws alone (L + R is the width-0 sum, so every octave band keeps its
//! energy); the default width decorrelates the channels; width jumps are ramped; impacts,
//! scraping and rolling are all stereo.

use realfft::RealFftPlanner;
use tactus::engine::materials::builtin_presets;
use tactus::engine::stereo::DEFAULT_WIDTH;
use tactus::engine::{Engine, Event, Settings};

const FS: f64 = 48_000.0;

/// An engine render of `len` samples in blocks of 256: a hit at 0 and one at 0.3 s, and, when
/// `contacts`, a scrape from 0.5 s and a roll from 1.0 s. `width_at(sample)` is the width of
/// the block starting there.
fn render(
    material: usize,
    seed: u64,
    len: usize,
    contacts: bool,
    width_at: impl Fn(usize) -> f64,
) -> (Vec<f32>, Vec<f32>) {
    let presets = builtin_presets();
    let mut e = Engine::with_library(&presets, material, 8, seed);
    e.prepare(FS, 256);
    let (mut l, mut r) = (vec![0.0f32; len], vec![0.0f32; len]);
    let block = 256;
    for (i, (lb, rb)) in l.chunks_mut(block).zip(r.chunks_mut(block)).enumerate() {
        let at = i * block;
        let mut s = Settings::default();
        s.output.width = width_at(at);
        if contacts && at >= FS as usize / 2 {
            s.scrape.speed_m_per_s = 0.4;
        }
        if contacts && at >= FS as usize {
            s.roll.speed_m_per_s = 0.5;
        }
        let hit = |key| Event::Impact {
            offset: 0,
            velocity_m_per_s: 1.5,
            pitch_factor: 1.0,
            key,
        };
        let events: Vec<Event> = if at == 0 {
            vec![hit(60)]
        } else if at == (0.3 * FS) as usize / block * block {
            vec![hit(62)]
        } else {
            vec![]
        };
        e.process(&s, &events, lb, rb);
    }
    (l, r)
}

/// Energy per octave band (centres 31.5 Hz … 16 kHz, edges at centre·2^±½) of `x`.
fn octave_energies(x: &[f32]) -> Vec<f64> {
    let n = x.len();
    let mut buf: Vec<f64> = x.iter().map(|&v| v as f64).collect();
    let mut spec = vec![realfft::num_complex::Complex::new(0.0, 0.0); n / 2 + 1];
    RealFftPlanner::<f64>::new()
        .plan_fft_forward(n)
        .process(&mut buf, &mut spec)
        .unwrap();
    (0..10)
        .map(|b| {
            let c = 31.25 * 2f64.powi(b);
            let (lo, hi) = (c / 2f64.sqrt(), c * 2f64.sqrt());
            spec.iter()
                .enumerate()
                .filter(|(k, _)| {
                    let f = *k as f64 * FS / n as f64;
                    f >= lo && f < hi
                })
                .map(|(_, v)| v.norm_sqr())
                .sum()
        })
        .collect()
}

fn sum(l: &[f32], r: &[f32]) -> Vec<f32> {
    l.iter().zip(r).map(|(a, b)| a + b).collect()
}

/// Inter-channel correlation at lag 0: `Σ L·R / √(Σ L² · Σ R²)`.
fn correlation(l: &[f32], r: &[f32]) -> f64 {
    let (mut lr, mut ll, mut rr) = (0.0f64, 0.0f64, 0.0f64);
    for (&a, &b) in l.iter().zip(r) {
        let (a, b) = (a as f64, b as f64);
        lr += a * b;
        ll += a * a;
        rr += b * b;
    }
    lr / (ll * rr).sqrt()
}

#[test]
fn width_zero_is_mono() {
    for material in [0, 3, 6] {
        let (l, r) = render(material, 11, 2 * FS as usize, true, |_| 0.0);
        assert!(l.iter().any(|&v| v != 0.0));
        assert!(l == r, "material {material}: channels differ at width 0");
    }
}

/// Per octave band, L + R at the default width and at width 1 is within 3 dB of the width-0 sum
/// (it is the same sum up to f32 rounding: the width moves energy between the channels, never
/// out of the sum); impacts, scrape and roll.
#[test]
fn every_octave_band_keeps_its_energy_in_the_sum() {
    let len = 2 * FS as usize;
    for material in [0, 2, 4] {
        let (l0, r0) = render(material, 5, len, true, |_| 0.0);
        let mono = octave_energies(&sum(&l0, &r0));
        let top = mono.iter().cloned().fold(0.0, f64::max);
        for width in [DEFAULT_WIDTH, 1.0] {
            let (l, r) = render(material, 5, len, true, |_| width);
            assert!(l != r, "material {material}, width {width}: mono");
            let wide = octave_energies(&sum(&l, &r));
            let mut worst = 0.0f64;
            for (a, b) in wide.iter().zip(&mono) {
                // Bands 100 dB under the loudest hold rounding only.
                if *b > 1e-10 * top {
                    worst = worst.max((10.0 * (a / b).log10()).abs());
                }
            }
            println!(
                "material {material}, width {width}: worst octave band of L+R vs width 0: {worst:.4} dB"
            );
            assert!(worst < 3.0, "material {material}, width {width}: {worst} dB");
        }
    }
}

/// The default width decorrelates the channels, within the target 0.3…0.97 for every built-in
/// material (a hit and a re-hit); width 1 decorrelates more.
#[test]
fn default_width_correlation_lies_in_its_target() {
    let len = FS as usize;
    let presets = builtin_presets();
    for material in 0..presets.len() {
        let (l, r) = render(material, 1, len, false, |_| DEFAULT_WIDTH);
        let c = correlation(&l, &r);
        let (l1, r1) = render(material, 1, len, false, |_| 1.0);
        let c1 = correlation(&l1, &r1);
        println!(
            "{}: correlation {c:.3} at width {DEFAULT_WIDTH}, {c1:.3} at width 1",
            presets[material].name
        );
        assert!((0.3..=0.97).contains(&c), "{}: {c}", presets[material].name);
        assert!(c1 < c, "{}: width 1 {c1} vs default {c}", presets[material].name);
    }
}

/// A width jump on ringing modes is ramped. Per sample, `L = M + w·S` moves by
/// `ΔM + w·ΔS + Δw·S`: for any `w` in 0..1 the first two terms lie between the width-0 and the
/// width-1 render's steps, and the ramp adds at most `|S|/480` (10 ms at 48 kHz). A jump
/// without the ramp would add the whole `|S|` at one sample.
#[test]
fn width_jumps_do_not_click() {
    let len = FS as usize / 2;
    let jump = 256 * 40;
    let (l, r) = render(1, 3, len, false, |at| if at < jump { 0.0 } else { 1.0 });
    let (l0, r0) = render(1, 3, len, false, |_| 0.0);
    let (l1, r1) = render(1, 3, len, false, |_| 1.0);
    let window = jump - 64..jump + 1024;
    let side_max = window
        .clone()
        .map(|n| ((l1[n] - r1[n]) / 2.0).abs())
        .fold(0.0f32, f32::max);
    assert!(side_max > 0.0);
    for (jumped, mono, wide) in [(&l, &l0, &l1), (&r, &r0, &r1)] {
        for n in window.clone() {
            let step = |x: &[f32]| (x[n] - x[n - 1]).abs();
            let bound = step(mono).max(step(wide)) + side_max / 100.0;
            assert!(
                step(jumped) <= bound,
                "sample {n}: step {} > {bound} (|S| up to {side_max})",
                step(jumped)
            );
        }
    }
}
