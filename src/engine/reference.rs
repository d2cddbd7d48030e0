//! f64 reference renderers for the modal bank (docs/model.md §2, Traer eq. 2): the same
//! discrete-time model as [`super::modal::ModalBank`], `y[n] = Σ_m Σ_j g_m·x[j]·e^{−d_m(n−j)}·
//! cos(ω_m(n−j))`, i.e. the closed-form damped cosines convolved with the sampled impulse input.
//! Used by tests and benchmarks as ground truth; not for the audio thread (allocates, slow).
//!
//! - [`render_modes_f64`]: closed form, every term evaluated directly with `exp`/`cos` (no
//!   recursion, so no accumulated rounding). Cost ∝ modes × non-zero inputs × length: meant for
//!   sparse (impulsive) inputs.
//! - [`render_modes_f64_recursive`]: the exact complex one-pole recursion in f64 (rounding
//!   ~1e−16 per sample), for dense inputs such as scraping forces.
//!
//! Modes are dropped by the same rule as the bank ([`ModeParams::pole`]).

use super::modal::ModeParams;

/// Closed-form response of `modes` to the impulse sequence `input` (N·s per sample), `len`
/// samples long. Inputs beyond `len` are ignored; zero inputs cost nothing.
pub fn render_modes_f64(modes: &[ModeParams], sample_rate: f64, input: &[f64], len: usize) -> Vec<f64> {
    let mut out = vec![0.0; len];
    let poles: Vec<(f64, f64, f64)> = modes
        .iter()
        .filter_map(|m| m.pole(sample_rate).map(|(d, w)| (d, w, m.gain)))
        .collect();
    for (j, &x) in input.iter().enumerate().take(len) {
        if x == 0.0 {
            continue;
        }
        for &(d, w, g) in &poles {
            let a = g * x;
            for (k, o) in out[j..].iter_mut().enumerate() {
                let t = k as f64;
                *o += a * (-d * t).exp() * (w * t).cos();
            }
        }
    }
    out
}

/// Closed-form response of modes that build up (docs/model.md "Build-up"): each
/// `(mode, rise_s)` rings as `g·e^{−dk}·(1 − e^{−k/τ})·cos(ωk)` per unit impulse (τ = `rise_s`
/// in samples; `rise_s` ≤ 0: no build-up), convolved with `input` as [`render_modes_f64`].
/// Evaluated from that product directly, not as the engine's pair of resonators, so it checks
/// the pair.
pub fn render_build_up_f64(
    modes: &[(ModeParams, f64)],
    sample_rate: f64,
    input: &[f64],
    len: usize,
) -> Vec<f64> {
    let mut out = vec![0.0; len];
    for (j, &x) in input.iter().enumerate().take(len) {
        if x == 0.0 {
            continue;
        }
        for (m, rise_s) in modes {
            let Some((d, w)) = m.pole(sample_rate) else {
                continue;
            };
            let tau = rise_s * sample_rate;
            let a = m.gain * x;
            for (k, o) in out[j..].iter_mut().enumerate() {
                let t = k as f64;
                let rise = if tau > 0.0 { 1.0 - (-t / tau).exp() } else { 1.0 };
                *o += a * (-d * t).exp() * rise * (w * t).cos();
            }
        }
    }
    out
}

/// The bank's recursion `z[n] = p·z[n−1] + g·x[n]`, `y = Re z`, in f64, `len` samples long.
pub fn render_modes_f64_recursive(
    modes: &[ModeParams],
    sample_rate: f64,
    input: &[f64],
    len: usize,
) -> Vec<f64> {
    let mut out = vec![0.0; len];
    for m in modes {
        let Some((d, w)) = m.pole(sample_rate) else {
            continue;
        };
        let r = (-d).exp();
        let (pr, pi) = (r * w.cos(), r * w.sin());
        let (mut zr, mut zi) = (0.0f64, 0.0f64);
        for (n, o) in out.iter_mut().enumerate() {
            let x = input.get(n).copied().unwrap_or(0.0);
            let nr = pr * zr - pi * zi + m.gain * x;
            zi = pr * zi + pi * zr;
            zr = nr;
            *o += zr;
        }
    }
    out
}

/// Signal-to-noise ratio in dB of `test` against `reference` (same length assumed; the
/// shorter length is used): `10·log10(Σ ref² / Σ (test − ref)²)`.
pub fn snr_db(reference: &[f64], test: &[f64]) -> f64 {
    let (mut s, mut e) = (0.0f64, 0.0f64);
    for (r, t) in reference.iter().zip(test) {
        s += r * r;
        e += (t - r) * (t - r);
    }
    10.0 * (s / e).log10()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_and_recursion_agree() {
        let modes = [
            ModeParams {
                freq_hz: 523.0,
                decay_db_per_s: 4.0,
                gain: 1.0,
            },
            ModeParams {
                freq_hz: 7_000.0,
                decay_db_per_s: 40.0,
                gain: 0.5,
            },
            // Dropped by both: above 0.49·fs.
            ModeParams {
                freq_hz: 23_600.0,
                decay_db_per_s: 0.0,
                gain: 1.0,
            },
        ];
        let mut x = vec![0.0; 5000];
        x[0] = 1.0;
        x[1234] = -0.3;
        let a = render_modes_f64(&modes, 48_000.0, &x, 5000);
        let b = render_modes_f64_recursive(&modes, 48_000.0, &x, 5000);
        assert!(snr_db(&a, &b) > 200.0, "snr {}", snr_db(&a, &b));
        assert!((a[0] - 1.5).abs() < 1e-12);
    }
}
