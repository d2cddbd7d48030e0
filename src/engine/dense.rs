//! Drawing a preset's dense mode field (docs/model.md, "Dense mode field";
//! [`crate::preset::DenseField`]): per band a Poisson number of modes, frequencies stratified in
//! log-frequency within the band (one uniform in each of as many equal parts as modes), levels Gaussian in dB relative to the object's strongest mode,
//! decays log-normal, polarities random. Runs after every other draw of an object, on the same RNG stream, so
//! a preset without a field draws exactly the numbers it always drew. Never allocates.

use super::limits::MAX_MODES;
use super::object::{EngineRng, ObjectMode};
use crate::preset::{DenseField, DECAY_RANGE_DB_PER_S};
use rand::RngExt;
use rand_distr::{Distribution, Poisson, StandardNormal};

/// Most bands whose counts [`add_dense_modes`] holds at once (the field's validated maximum).
const BANDS: usize = crate::preset::dense::MAX_DENSE_BANDS;

/// Adds `field`'s modes to `modes` (an object's drawn modes, which set the reference level:
/// their strongest) and sorts them all by frequency. `shift_octaves` moves every band (the
/// drawn object's size shift, so that its dense partials move with its fitted ones).
/// `resonators` is how many resonators `modes` already take (a mode that builds up takes
/// two, the field's own included): the field adds modes taking at most [`MAX_MODES`] minus
/// that, thinning every band's count by the same factor when the draw asks for more. Never
/// allocates: `modes` has [`MAX_MODES`] room.
pub fn add_dense_modes(
    field: &DenseField,
    shift_octaves: f64,
    resonators: usize,
    rng: &mut EngineRng,
    modes: &mut Vec<ObjectMode>,
) {
    let strongest = modes.iter().map(|m| m.level_db).fold(f64::NEG_INFINITY, f64::max);
    // An object with no modes of its own has no level to be relative to: its dense modes are
    // relative to 0 dB, the level of a preset's strongest mean mode.
    let reference = if strongest.is_finite() { strongest } else { 0.0 };
    // In resonators: a mode that builds up takes two.
    let room = MAX_MODES.saturating_sub(resonators.max(modes.len()));
    let bands = &field.bands[..field.bands.len().min(BANDS)];
    let mut counts = [0usize; BANDS];
    for (c, b) in counts.iter_mut().zip(bands) {
        // `Poisson::new` refuses a mean of 0 (and non-finite ones, which validation excludes).
        *c = match Poisson::new(b.modes) {
            Ok(p) => {
                let n: f64 = p.sample(rng);
                n.min(MAX_MODES as f64) as usize
            }
            Err(_) => 0,
        };
    }
    let total: usize = counts
        .iter()
        .zip(bands)
        .map(|(c, b)| c * b.resonators_per_mode())
        .sum();
    if total > room {
        // Proportional thinning, the remainder handed out one mode per band from the lowest
        // while it fits: every band keeps its share of the field.
        let mut kept = 0;
        for (c, b) in counts.iter_mut().zip(bands) {
            *c = *c * room / total;
            kept += *c * b.resonators_per_mode();
        }
        for (c, b) in counts.iter_mut().zip(bands) {
            if kept + b.resonators_per_mode() <= room {
                *c += 1;
                kept += b.resonators_per_mode();
            }
        }
    }
    let scale = shift_octaves.exp2();
    let scale = if scale.is_finite() { scale } else { 1.0 };
    for (&n, b) in counts.iter().zip(bands) {
        let (lo, hi) = (b.low_hz.log2(), b.high_hz.log2());
        for i in 0..n {
            if modes.len() >= MAX_MODES {
                break;
            }
            // One mode per stratum: a shell's eigenfrequencies repel each other (Wigner
            // spacings), where independent uniform draws put pairs within one bin, which sound
            // and count as one peak (docs/model.md, "Dense mode field").
            let u: f64 = rng.random();
            let zl: f64 = rng.sample(StandardNormal);
            let zd: f64 = rng.sample(StandardNormal);
            // A mode's sign at the pickup is that of the product of its shape at the strike
            // and at the pickup, which for modes of high order is as often negative as
            // positive. Hundreds of modes all started in phase sum to a click: pairs closer
            // than ~100 Hz add coherently over the first 10 ms, and a China Cymbal draw held
            // 20 % of its energy there against its recordings' 1.4–3.4 %.
            let inverted: bool = rng.random();
            let level = (b.level_db + b.level_sd_db * zl).min(0.0);
            modes.push(ObjectMode {
                freq_hz: (lo + (i as f64 + u) / n as f64 * (hi - lo)).exp2() * scale,
                level_db: reference + level,
                decay_db_per_s: (b.ln_decay + b.ln_decay_sd * zd)
                    .exp()
                    .clamp(DECAY_RANGE_DB_PER_S.0, DECAY_RANGE_DB_PER_S.1),
                rise_s: b.rise_s,
                ring: Default::default(),
                inverted,
            });
        }
    }
    modes.sort_unstable_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
}
