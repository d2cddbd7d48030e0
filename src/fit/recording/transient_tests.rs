//! Tests of [`super`]: the transient refit's quadratic form against the synthesised resynthesis.

use super::*;
use crate::fit::recording::bands::synthesize_transient;

/// The quadratic form [`refit_for_draws`] optimises is the band energy of the actual
/// resynthesis: modes plus [`synthesize_transient`] at any levels, same seed. Tolerance
/// 10⁻⁴ relative (0.0004 dB): the cross terms of the bands [`draw_observations`] leaves out
/// (< 10⁻⁹ of their energy in the band) are of order √(10⁻⁹·own/em); measured 2.7·10⁻⁵.
#[test]
fn draw_band_energies_match_the_synthesised_resynthesis() {
    let fs = 24_000.0;
    let n = 9_000;
    let modal: Vec<f64> = (0..n)
        .map(|t| {
            let t = t as f64 / fs;
            (-30.0 * t).exp() * (std::f64::consts::TAU * 440.0 * t).sin()
                + 0.3 * (-200.0 * t).exp() * (std::f64::consts::TAU * 3_100.0 * t).sin()
        })
        .collect();
    let bands: Vec<Option<(f64, f64)>> = (0..BANDS)
        .map(|i| (i % 7 != 3).then(|| (-40.0 + 0.7 * i as f64, 150.0 + 90.0 * i as f64)))
        .collect();
    let decays: Vec<Option<f64>> = bands.iter().map(|b| b.map(|(_, d)| d)).collect();
    let free: Vec<usize> = (0..BANDS).filter(|&i| bands[i].is_some()).collect();
    let used: Vec<usize> = (0..BANDS).collect();
    let obs = draw_observations(&decays, &free, &used, &modal, fs, 7..8);
    let g: Vec<f64> = free
        .iter()
        .map(|&i| 10f64.powf(bands[i].unwrap().0 / 20.0))
        .collect();
    let tr = synthesize_transient(&bands, fs, n, 7);
    let x: Vec<f64> = modal.iter().zip(&tr).map(|(a, b)| a + b).collect();
    let want = band_energies_up_to(&x, fs, analysis_high_hz(fs));
    let mut checked = 0;
    for o in &obs {
        let (e, _) = o.energy(&g);
        let w = want[o.band];
        assert!(
            (e - w).abs() <= 1e-4 * w + 1e-15,
            "band {}: quadratic form {e:e}, resynthesis {w:e}",
            o.band
        );
        checked += 1;
    }
    assert!(checked >= 25, "only {checked} bands compared");
}

/// `n` samples at `fs` of 80 partials every ~6 % from 100 Hz up, each at 0.05, decaying at
/// 30 dB/s: a cymbal's counted partials, beside which its gap is strike and wash.
fn partials_at_30_db_per_s(fs: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let t = i as f64 / fs;
            let ring = 10f64.powf(-30.0 * t / 20.0);
            (0..80)
                .map(|j| 0.05 * ring * (std::f64::consts::TAU * 100.0 * 1.06f64.powi(j) * t).cos())
                .sum::<f64>()
        })
        .collect()
}

/// A gap that is strike and wash at once (a 4 ms burst of noise over a noise that rings for
/// seconds, under partials that ring as long: what a cymbal's counted partials leave): read by
/// its early share, the fitted band noise holds the gap's share of energy in the attack window
/// (within 30 %); the line through its dB track stops where the partials explain a frame,
/// reads the burst's fall, and puts more of the energy there.
#[test]
fn early_share_puts_the_gaps_energy_where_the_gap_has_it() {
    use rand::{RngExt, SeedableRng};
    let fs = 24_000.0;
    let n = 48_000;
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    // Partials every ~6 % from 100 Hz up, ringing as long as the wash: the modes that explain
    // most frames, leaving the gap zero in some.
    let modal = partials_at_30_db_per_s(fs, n);
    let y: Vec<f64> = modal
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let t = i as f64 / fs;
            let v = rng.random::<f64>() - 0.5;
            m + v * (0.2 * 10f64.powf(-30.0 * t / 20.0) + if t < 0.004 { 0.3 } else { 0.0 })
        })
        .collect();
    let gap: Vec<f64> = y.iter().zip(&modal).map(|(a, b)| a - b).collect();
    let share = |x: &[f64]| crate::analysis::features::attack_share(x, fs);
    let want = share(&gap);
    let got = |read| {
        share(&synthesize_transient(
            &fit_transient_gap_decaying(&y, &modal, fs, 0.0, read),
            fs,
            n,
            1,
        ))
    };
    let (early, line) = (got(GapDecay::EarlyShare), got(GapDecay::Line));
    assert!(
        (early / want - 1.0).abs() < 0.3,
        "early share: noise {early:.3}, gap {want:.3}"
    );
    println!("attack-window share: gap {want:.3}, early-share noise {early:.3}, line noise {line:.3}");
    assert!(line > 1.5 * want, "line: noise {line:.3}, gap {want:.3}");
}

/// A wash that swells after the strike (as a crash cymbal's does) over partials ringing at
/// 30 dB/s: the gap's first 10 ms hold so little of its energy that their share alone reads a
/// decay under 10 dB/s, a hiss outlasting the partials. Read by its early share, each band the
/// partials fill (≥ 1 % of its energy) decays no slower than they do (within 20 %: their band
/// track's energy decay).
#[test]
fn early_share_noise_rings_no_longer_than_the_partials_beside_it() {
    use rand::{RngExt, SeedableRng};
    let fs = 24_000.0;
    let n = 72_000;
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let ring = |t: f64| 10f64.powf(-30.0 * t / 20.0);
    let modal = partials_at_30_db_per_s(fs, n);
    let y: Vec<f64> = modal
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let t = i as f64 / fs;
            let swell = 1.0 - (-t / 0.15).exp();
            m + (rng.random::<f64>() - 0.5) * (0.2 * swell * ring(t) + if t < 0.002 { 0.1 } else { 0.0 })
        })
        .collect();
    let gap: Vec<f64> = y.iter().zip(&modal).map(|(a, b)| a - b).collect();
    let share = crate::analysis::features::attack_share(&gap, fs);
    let by_share = -10.0 * (1.0 - share).log10() / ATTACK_WINDOW_S;
    assert!(
        by_share < 10.0,
        "the gap's early share {share:.4} reads {by_share:.1} dB/s"
    );
    let (ey, em) = (band_energies(&y, fs), band_energies(&modal, fs));
    let fitted = fit_transient_gap_decaying(&y, &modal, fs, 0.0, GapDecay::EarlyShare);
    let mut checked = 0;
    for (band, b) in fitted.iter().enumerate() {
        let Some((_, decay)) = b else { continue };
        if em[band] < BESIDE_MIN_SHARE * ey[band] {
            continue;
        }
        assert!(
            *decay >= 24.0,
            "band {band}: noise decays at {decay:.1} dB/s beside partials at 30"
        );
        checked += 1;
    }
    assert!(checked >= 15, "only {checked} bands checked");
}
