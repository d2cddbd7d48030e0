//! Perceptual culling policy (docs/model.md §8): which modes and noise bands the engine stops
//! computing, and when. Three rules, all decided here:
//! - **relative**: a mode more than `quality` dB below the strongest (at the hit: the hit's
//!   strongest mode; later: its voice's strongest current mode; for noise bands: the
//!   transient's strongest band), or below the absolute floor [`MODE_FLOOR`];
//! - **threshold of hearing** at an assumed playback level ([`PLAYBACK_SPL_OFFSET_DB`]);
//! - **simultaneous masking** by every sounding mode of the scene, every [`MASKING_EVERY`]-th
//!   housekeeping, with a margin that grows with `quality` ([`masking_margin_db`]).
//!
//! A mode that builds up is two resonators ([`super::modal::build_up_pair`]): the rule at the
//! hit takes or drops both on the mode's level; later each is retired on its own state, and
//! the partner (same frequency, same |gain|, faster decay) is never the louder of the two
//! after a contact, so it meets every floor no later than its mode. A mode that rings is two
//! resonators too ([`super::modal::ring_pair`]), taken or dropped together at the hit; later
//! the knock and the (slower) ring are each retired on their own state, the knock first.
//!
//! The per-bank kernels that apply the floors stay with their banks
//! ([`ModalBank::retire_masked`], [`crate::engine::transient::TransientBank::cull`],
//! [`Maskers`]); this module computes the floors and scales they are given.

use super::modal::{Maskers, ModalBank};
use super::voices::Voices;
use super::{Lifecycle, HOUSEKEEPING_INTERVAL};

/// A single mode is retired when its magnitude falls below this (−130 dBFS): far below the
/// sleep floor, so even a few dozen retired modes together stay inaudible.
pub const MODE_FLOOR: f32 = 3.162e-7;

/// Playback level of digital full scale assumed by the absolute-threshold culling, minus the
/// `quality` setting (dB SPL): at quality 60, 0 dBFS = 110 dB SPL.
pub const PLAYBACK_SPL_OFFSET_DB: f64 = 50.0;

/// Safety margin of the masking culling per dB of `quality` above [`MASKING_MARGIN_FROM_QUALITY`]:
/// the margin is `(quality − 60) / 4` dB, so the default masks at the model's threshold (the
/// MPEG-1 tonal masking index with the steepest, level-independent slopes and each band's
/// farthest point: already a lower bound of the masking threshold), and a higher quality masks
/// less (15 dB margin at 120, 60 dB at 300).
pub const MASKING_MARGIN_PER_QUALITY: f64 = 0.25;

/// The `quality` at and below which the masking margin is 0 dB (the default quality).
pub const MASKING_MARGIN_FROM_QUALITY: f64 = 60.0;

/// The masking margin (dB) at `quality_db`.
pub fn masking_margin_db(quality_db: f64) -> f64 {
    (quality_db - MASKING_MARGIN_FROM_QUALITY).max(0.0) * MASKING_MARGIN_PER_QUALITY
}

/// The masking culling runs at every `MASKING_EVERY`-th housekeeping: masking changes slowly
/// (decays of tens of dB per second) and the pass scans every mode of every voice.
pub const MASKING_EVERY: u64 = 4;

/// The relative rule at a hit: whether a mode of onset level `level_db` is not started because it
/// lies more than `quality_db` below the hit's strongest mode (`strongest_db`).
#[inline]
pub(super) fn cut_at_hit(level_db: f64, strongest_db: f64, quality_db: f64) -> bool {
    level_db < strongest_db - quality_db
}

/// The culling state: the scene's masking threshold grid (allocated once, rebuilt by every
/// masking pass).
pub(super) struct Culling {
    sample_rate_hz: f64,
    maskers: Maskers,
}

impl Culling {
    pub(super) fn new(sample_rate_hz: f64) -> Self {
        Self {
            sample_rate_hz,
            maskers: Maskers::new(),
        }
    }

    /// One housekeeping's culling of the voices' free-ringing modes and noise bands, at engine
    /// time `time` (a multiple of [`HOUSEKEEPING_INTERVAL`]). A voice whose contact still runs
    /// is left alone: its modes are still being excited. With `enabled` off only modes whose
    /// state is exactly 0 (flushed) or non-finite are retired.
    pub(super) fn housekeeping(&mut self, voices: &mut Voices, quality_db: f64, enabled: bool, time: u64) {
        // A free-ringing mode more than `quality_db` below the voice's strongest mode, or below
        // the per-mode floor, only decays further relative to the others it falls behind: it is
        // retired for good.
        let rel = 10f64.powf(-quality_db / 20.0);
        // Absolute threshold: full scale is assumed to play at `PLAYBACK_SPL_OFFSET_DB + quality`
        // dB SPL (110 dB SPL at the default quality 60, louder than any sane monitoring level);
        // a mode below the threshold of hearing at its frequency at that level is inaudible
        // whatever else sounds (Raghuvanshi & Lin's absolute-threshold culling).
        let threshold_scale = 10f64.powf(-(PLAYBACK_SPL_OFFSET_DB + quality_db) / 10.0);
        // Simultaneous masking across all voices (`modal::Maskers`): the loudest modes of the
        // scene mask what lies far enough below them and decays at least as fast.
        let masking = enabled && (time / HOUSEKEEPING_INTERVAL).is_multiple_of(MASKING_EVERY);
        if masking {
            self.maskers.begin(
                masking_margin_db(quality_db),
                (MASKING_EVERY * HOUSEKEEPING_INTERVAL) as f64 / self.sample_rate_hz,
            );
            for v in voices.active() {
                v.bank.collect_maskers(&mut self.maskers);
            }
            self.maskers.finish();
        }
        let mut maskers = masking.then_some(&mut self.maskers);
        for v in voices.active_mut().filter(|v| !v.force.is_active()) {
            if enabled {
                let strongest = v.bank.max_energy().sqrt();
                let floor = (strongest * rel).max(MODE_FLOOR as f64);
                v.bank
                    .retire_masked(floor, threshold_scale, maskers.as_deref_mut());
                // The noise bands by the same rules: `quality` dB below the transient's strongest
                // band (not below the strongest mode: a transient spread over 30 bands, each far
                // below a loud mode, measured up to 4 dB off in one frame of the metal impact),
                // the −130 dBFS floor and the threshold of hearing (a band's envelope only falls:
                // below those two it stays inaudible).
                let band_floor = (v.transient.max_env() * rel as f32).max(MODE_FLOOR);
                v.transient.cull(band_floor, threshold_scale);
            } else {
                retire_flushed(&mut v.bank);
            }
        }
    }
}

/// Retires only the modes whose state is exactly 0 (flushed) or non-finite: what runs when
/// culling is off.
fn retire_flushed(bank: &mut ModalBank) {
    bank.retire_below(f32::MIN_POSITIVE);
}

impl Lifecycle for Culling {
    fn prepare(&mut self, sample_rate_hz: f64, _max_block: usize) {
        self.sample_rate_hz = sample_rate_hz;
    }

    fn reset(&mut self) {
        self.maskers.clear_removed();
    }
}
