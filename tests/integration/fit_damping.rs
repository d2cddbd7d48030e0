//! EMG damping fit (Sterling 2019 §1.2) on synthetic Rayleigh data with exponential outliers.

use rand::{RngExt, SeedableRng};
use tactus::fit::pool::damping::{fit_emg, fit_least_squares, fit_lower_bound, ln_erfc};

#[test]
fn ln_erfc_is_accurate_and_safe() {
    // erfc(0) = 1, erfc(1) = 0.157299207, erfc(-1) = 1.842700793, erfc(30) ~ 2.56e-393.
    assert!(ln_erfc(0.0).abs() < 1e-6);
    assert!((ln_erfc(1.0) - 0.157_299_207f64.ln()).abs() < 1e-6);
    assert!((ln_erfc(-1.0) - 1.842_700_793f64.ln()).abs() < 1e-6);
    let v = ln_erfc(30.0);
    assert!(v.is_finite() && (v - (-904.8)).abs() < 1.0, "{v}");
}

#[test]
fn emg_beats_least_squares_with_outliers() {
    let (a1, a2) = (39.0, 1.3e-7); // wood, Sterling Table 1.1
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let (mut w, mut c) = (Vec::new(), Vec::new());
    for _ in 0..300 {
        let f = 200.0 * 40f64.powf(rng.random::<f64>());
        let om = std::f64::consts::TAU * f;
        let u1: f64 = rng.random::<f64>().max(1e-300);
        let g = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * rng.random::<f64>()).cos();
        // σ = 3/s Gaussian noise; exponential outliers with mean 40/s (η = 1/40 s).
        let e = -40.0 * rng.random::<f64>().max(1e-300).ln();
        w.push(om);
        c.push(a1 + a2 * om * om + 3.0 * g + e);
    }
    let emg = fit_emg(&w, &c, false).expect("fit");
    let ls = fit_least_squares(&w, &c);
    let lb = fit_lower_bound(&w, &c);
    let rel = |x: f64, t: f64| (x - t).abs() / t;
    eprintln!(
        "EMG a1 {:.2} ({:.1} %) a2 {:.3e} ({:.1} %) sigma {:.2} 1/eta {:.1}",
        emg.alpha1,
        100.0 * rel(emg.alpha1, a1),
        emg.alpha2,
        100.0 * rel(emg.alpha2, a2),
        emg.sigma,
        1.0 / emg.eta
    );
    eprintln!(
        "LS  a1 {:.2} ({:.1} %) a2 {:.3e} ({:.1} %)",
        ls.alpha1,
        100.0 * rel(ls.alpha1, a1),
        ls.alpha2,
        100.0 * rel(ls.alpha2, a2)
    );
    eprintln!(
        "LB  a1 {:.2} ({:.1} %) a2 {:.3e} ({:.1} %)",
        lb.alpha1,
        100.0 * rel(lb.alpha1, a1),
        lb.alpha2,
        100.0 * rel(lb.alpha2, a2)
    );
    assert!(rel(emg.alpha1, a1) <= 0.10);
    assert!(rel(emg.alpha2, a2) <= 0.10);
    assert!(rel(emg.alpha1, a1) < rel(ls.alpha1, a1));
    let hyb = fit_emg(&w, &c, true).expect("hybrid fit");
    eprintln!(
        "hybrid a1 {:.2} a2 {:.3e} a3 {:.3}",
        hyb.alpha1, hyb.alpha2, hyb.alpha3
    );
    assert!((hyb.alpha3 - 1.0).abs() < 0.05);
}
