//! The dense mode field of a preset (docs/model.md, "Dense mode field"): for objects whose
//! recordings hold far more partials than a drawn object's fitted modes (a cymbal's hundreds),
//! a statistical description per frequency band of the partials beyond those modes: how many
//! per object, how loud relative to the object's strongest mode, how fast they decay. A draw
//! adds that many modes per band at random frequencies ([`crate::engine::dense`]); a preset
//! without the block draws as before.

use super::{check_range, err, PresetError, DECAY_RANGE_DB_PER_S, FREQ_RANGE_HZ};
use crate::engine::limits::MAX_MODES;
use serde::{Deserialize, Serialize};

/// Most bands a dense field may have. Why 64: the fit uses third-octave bands (≤ 30 between
/// 20 Hz and 20 kHz); 64 leaves room for finer hand-written fields while bounding the draw's
/// per-band work.
pub const MAX_DENSE_BANDS: usize = 64;

/// Largest standard deviation of a band's level law, dB, and of its `ln` decay law: beyond
/// them a band's modes span more than the engine's whole dynamic range.
pub const MAX_LEVEL_SD_DB: f64 = 40.0;
/// See [`MAX_LEVEL_SD_DB`].
pub const MAX_LN_DECAY_SD: f64 = 3.0;

/// The dense mode field: one entry per frequency band, ascending and not overlapping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DenseField {
    /// The bands, ascending in frequency.
    pub bands: Vec<DenseBand>,
}

/// One band of a [`DenseField`]: its modes' count, level law and decay law.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DenseBand {
    /// Lower band edge, Hz (at `size = 1`).
    pub low_hz: f64,
    /// Upper band edge, Hz.
    pub high_hz: f64,
    /// Mean number of modes per drawn object (a Poisson mean, so fractional values are
    /// meaningful: 0.4 gives a mode in two objects out of five, on average).
    pub modes: f64,
    /// Mean onset level of a mode, dB relative to the drawn object's strongest mode (≤ 0 for
    /// modes weaker than it; the engine never lifts a dense mode above it).
    pub level_db: f64,
    /// Standard deviation of the level, dB (Gaussian in dB).
    pub level_sd_db: f64,
    /// Mean of `ln b`, `b` the decay in dB/s.
    pub ln_decay: f64,
    /// Standard deviation of `ln b` (log-normal decays).
    pub ln_decay_sd: f64,
    /// Build-up time constant τ of the band's modes, s (docs/model.md, "Dense mode field"): each
    /// swells as `1 − e^{−t/τ}` and takes two resonators. 0 (absent in a file) = none; up to
    /// [`MAX_RISE_S`](crate::preset::MAX_RISE_S).
    #[serde(default, skip_serializing_if = "crate::preset::is_zero")]
    pub rise_s: f64,
}

impl DenseField {
    /// Checks every band; `p` prefixes the field names (`""`, `"families[i]."`).
    pub(super) fn validate(&self, p: &str) -> Result<(), PresetError> {
        let at = format!("{p}dense.bands");
        if self.bands.is_empty() || self.bands.len() > MAX_DENSE_BANDS {
            return Err(err(
                &at,
                format!("must hold 1..={MAX_DENSE_BANDS} bands, got {}", self.bands.len()),
            ));
        }
        let mut prev_high = 0.0;
        for (i, b) in self.bands.iter().enumerate() {
            let f = |name: &str| format!("{at}[{i}].{name}");
            check_range(&f("low_hz"), b.low_hz, FREQ_RANGE_HZ)?;
            check_range(&f("high_hz"), b.high_hz, FREQ_RANGE_HZ)?;
            if b.high_hz <= b.low_hz {
                return Err(err(
                    f("high_hz"),
                    format!("must be above low_hz ({} Hz), got {} Hz", b.low_hz, b.high_hz),
                ));
            }
            if b.low_hz < prev_high {
                return Err(err(
                    f("low_hz"),
                    format!(
                        "bands must ascend without overlapping: {} Hz is below the previous band's high_hz {prev_high} Hz",
                        b.low_hz
                    ),
                ));
            }
            prev_high = b.high_hz;
            check_range(&f("modes"), b.modes, (0.0, MAX_MODES as f64))?;
            check_range(&f("level_db"), b.level_db, (-200.0, 0.0))?;
            check_range(&f("level_sd_db"), b.level_sd_db, (0.0, MAX_LEVEL_SD_DB))?;
            check_range(&f("ln_decay"), b.ln_decay, (-10.0, DECAY_RANGE_DB_PER_S.1.ln()))?;
            check_range(&f("ln_decay_sd"), b.ln_decay_sd, (0.0, MAX_LN_DECAY_SD))?;
            check_range(&f("rise_s"), b.rise_s, (0.0, crate::preset::MAX_RISE_S))?;
        }
        let total = self.expected_resonators();
        // The engine stops adding modes at its capacity; a field that asks for more on average
        // would have its upper bands cut in most draws, which is a wrong preset, not a draw.
        if total > MAX_MODES as f64 {
            return Err(err(
                &at,
                format!(
                    "the bands' modes take {total:.1} resonators per object (a mode that builds up takes two), more than the engine's {MAX_MODES}"
                ),
            ));
        }
        Ok(())
    }

    /// Expected number of modes per drawn object (Σ of the bands' means).
    pub fn expected_modes(&self) -> f64 {
        self.bands.iter().map(|b| b.modes).sum()
    }

    /// Whether any band's modes build up ([`DenseBand::rise_s`]).
    pub fn builds_up(&self) -> bool {
        self.bands.iter().any(|b| b.rise_s > 0.0)
    }

    /// Expected number of resonators the modes take per drawn object.
    pub fn expected_resonators(&self) -> f64 {
        self.bands
            .iter()
            .map(|b| b.modes * b.resonators_per_mode() as f64)
            .sum()
    }
}

impl DenseBand {
    /// Resonators one of the band's modes takes: two when it builds up.
    pub fn resonators_per_mode(&self) -> usize {
        crate::preset::resonator_slots(1, std::iter::once(self.rise_s > 0.0))
    }
}

#[cfg(test)]
mod tests {
    use crate::preset::{worst_case_preset, Preset};

    fn with_band(edit: impl Fn(&mut super::DenseBand)) -> Preset {
        let mut p = worst_case_preset();
        edit(&mut p.dense.as_mut().unwrap().bands[3]);
        p
    }

    /// Every bad value is refused with the field's full path and the reason.
    #[test]
    fn bad_dense_blocks_are_refused_by_field() {
        let cases: [(fn(&mut super::DenseBand), &str, &str); 8] = [
            (|b| b.modes = -1.0, "dense.bands[3].modes", "outside the range"),
            (|b| b.modes = f64::NAN, "dense.bands[3].modes", "finite"),
            (|b| b.high_hz = b.low_hz, "dense.bands[3].high_hz", "above low_hz"),
            (|b| b.low_hz = 50.0, "dense.bands[3].low_hz", "ascend"),
            (
                |b| b.level_db = 3.0,
                "dense.bands[3].level_db",
                "outside the range",
            ),
            (|b| b.level_sd_db = -1.0, "dense.bands[3].level_sd_db", "outside"),
            (|b| b.ln_decay_sd = 9.0, "dense.bands[3].ln_decay_sd", "outside"),
            (|b| b.rise_s = 2.0, "dense.bands[3].rise_s", "outside"),
        ];
        for (edit, field, why) in cases {
            let e = with_band(edit).validate().unwrap_err();
            assert_eq!(e.field, field, "{e}");
            assert!(e.to_string().contains(why), "{e}");
        }
        // Too many modes in total, and an empty field.
        let e = with_band(|b| b.modes = 200.0).validate().unwrap_err();
        assert_eq!(e.field, "dense.bands");
        assert!(e.reason.contains("more than the engine's 1024"), "{e}");
        // A mode that builds up takes two resonators: the worst case's field, at the limit in
        // modes, is refused once one band's modes build up.
        assert!(worst_case_preset().validate().is_ok());
        let e = with_band(|b| b.rise_s = 0.02).validate().unwrap_err();
        assert_eq!(e.field, "dense.bands");
        assert!(e.reason.contains("builds up takes two"), "{e}");
        let mut p = worst_case_preset();
        p.dense.as_mut().unwrap().bands.clear();
        assert_eq!(p.validate().unwrap_err().field, "dense.bands");
        // A family's field is named with its family.
        let mut p = worst_case_preset();
        p.families = vec![crate::preset::Family {
            name: "ride".into(),
            weight: 1.0,
            modes: p.modes.clone(),
            transient: None,
            damping: None,
            dense: p.dense.clone(),
            size_class: None,
        }];
        p.families[0].dense.as_mut().unwrap().bands[0].ln_decay = f64::INFINITY;
        let e = p.validate().unwrap_err();
        assert_eq!(e.field, "families[0].dense.bands[0].ln_decay");
    }

    /// A preset without a dense block writes none (old files round-trip unchanged), and a dense
    /// block round-trips.
    #[test]
    fn dense_block_is_optional_and_round_trips() {
        let mut p = worst_case_preset();
        let back = Preset::from_json(&p.to_json(), None).unwrap();
        let (a, b) = (p.dense.as_ref().unwrap(), back.dense.as_ref().unwrap());
        assert_eq!(a.bands.len(), b.bands.len());
        for (x, y) in a.bands.iter().zip(&b.bands) {
            // serde_json's float parsing may differ from the written value in the last bit.
            assert!((x.low_hz / y.low_hz - 1.0).abs() < 1e-12 && (x.modes / y.modes - 1.0).abs() < 1e-12);
            assert_eq!((x.level_db, x.ln_decay_sd), (y.level_db, y.ln_decay_sd));
            assert_eq!(y.rise_s, 0.0);
        }
        // A band without a build-up writes no `rise_s` (a version-4 band); one with it does.
        assert!(!p.to_json().contains("rise_s"));
        p.dense.as_mut().unwrap().bands[2].modes = 1.0;
        p.dense.as_mut().unwrap().bands[2].rise_s = 0.04;
        let back = Preset::from_json(&p.to_json(), None).unwrap();
        assert_eq!(back.dense.as_ref().unwrap().bands[2].rise_s, 0.04);
        assert_eq!(back.dense.as_ref().unwrap().bands[3].rise_s, 0.0);
        p.dense = None;
        assert!(!p.to_json().contains("dense"));
    }
}
