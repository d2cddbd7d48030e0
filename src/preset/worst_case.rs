//! The most expensive presets validation accepts: what the real-time, timing and allocation tests
//! (unit tests, the plugin's process tests, the host tests through `tactus preset worst-case`)
//! size the engine against.

use super::*;

/// The most expensive preset validation accepts, for real-time and timing tests: a distribution
/// of [`MAX_DISTRIBUTION_MODES`] modes with a full covariance (every Cholesky entry non-zero,
/// AR(1) correlation 0.9 between neighbouring coordinates), a spacing tolerance of 0 so that
/// every draw runs all [`crate::engine::object::MAX_REJECTION_TRIES`] rejection tries, a dense
/// field asking for [`MAX_MODES`] more modes (so every object fills the engine's mode limit),
/// and a transient of [`MAX_BANDS`] bands with a full covariance.
pub fn worst_case_preset() -> Preset {
    worst_case_with(MAX_DISTRIBUTION_MODES, 0.0)
}

/// As [`worst_case_preset`], with every distribution mode building up (τ = 5 ms): its
/// [`MAX_DISTRIBUTION_MODES`] modes take two resonators each, and the dense field fills the rest
/// of the engine's [`MAX_MODES`] (docs/model.md "Build-up").
pub fn worst_case_build_up_preset() -> Preset {
    worst_case_with(MAX_DISTRIBUTION_MODES, 0.005)
}

/// As [`worst_case_preset`], with every distribution mode ringing after its knock (share 0.5,
/// a tenth of its decay): two resonators each, as [`worst_case_build_up_preset`]'s
/// (docs/model.md "Ring").
pub fn worst_case_ring_preset() -> Preset {
    let mut p = worst_case_with(MAX_DISTRIBUTION_MODES, 0.0);
    if let ModeModel::Distribution(d) = &mut p.modes {
        d.rings = vec![
            ModeRing {
                share: 0.5,
                decay_ratio: 0.1,
            };
            d.count
        ];
    }
    p
}

fn worst_case_with(m: usize, rise_s: f64) -> Preset {
    fn ar1(n: usize, sd: f64) -> Vec<Vec<f64>> {
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| sd * sd * 0.9f64.powi((i as i32 - j as i32).abs()))
                    .collect()
            })
            .collect()
    }
    let (lo, hi) = (100f64.log2(), 16_000f64.log2());
    let mut mean = vec![-20.0; m];
    mean.extend(std::iter::repeat_n(3.0, m));
    mean.extend((0..m).map(|i| lo + (hi - lo) * i as f64 / (m - 1) as f64));
    let bands = MAX_BANDS;
    let mut tmean = vec![-40.0; bands];
    tmean.extend(std::iter::repeat_n(5.0, bands));
    Preset {
        format_version: FORMAT_VERSION,
        name: "Worst case".into(),
        material_class: "other".into(),
        origin: Origin::Provisional,
        provenance: Provenance::default(),
        modes: ModeModel::Distribution(ModeDistribution {
            count: m,
            gaussian: Gaussian {
                mean,
                covariance: ar1(3 * m, 0.05),
            },
            mean_spacing_octaves: (hi - lo) / (m - 1) as f64,
            spacing_tolerance: 0.0,
            decay: DecayCoordinates::Absolute,
            rise_s: if rise_s > 0.0 { vec![rise_s; m] } else { Vec::new() },
            rings: Vec::new(),
        }),
        transient: Some(TransientDistribution {
            bands,
            low_hz: 100.0,
            high_hz: 16_000.0,
            gaussian: Gaussian {
                mean: tmean,
                covariance: ar1(2 * bands, 0.5),
            },
        }),
        damping: None,
        contact_stiffness_n_per_m: 1e6,
        contact_exponent: crate::engine::force::HC_DEFAULT_EXPONENT,
        families: Vec::new(),
        dense: Some(worst_case_dense()),
    }
}

/// A dense field of third-octave bands over 100 Hz–16 kHz whose means sum to [`MAX_MODES`]:
/// every draw fills the engine's mode limit, whatever the distribution already holds.
fn worst_case_dense() -> DenseField {
    let edges: Vec<f64> = (0..=22).map(|k| 100.0 * 2f64.powf(k as f64 / 3.0)).collect();
    let n = edges.len() - 1;
    DenseField {
        bands: edges
            .windows(2)
            .map(|e| DenseBand {
                low_hz: e[0],
                high_hz: e[1],
                modes: MAX_MODES as f64 / n as f64,
                level_db: -20.0,
                level_sd_db: 6.0,
                ln_decay: 3.0,
                ln_decay_sd: 0.5,
                rise_s: 0.0,
            })
            .collect(),
    }
}
