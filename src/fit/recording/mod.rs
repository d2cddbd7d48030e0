//! One recording → its extracted modes, strike noise (transient), ringing partials and
//! resynthesis distance ([`fit_file`]), what [`crate::fit::pool`] pools into a preset.

pub mod bands;
pub mod dense;
pub mod extract;
mod lsq;
pub mod modes;
pub mod ring;
pub mod transient;

use crate::analysis::signal::{self, energy_db, Mode};
use crate::analysis::{audio, partials};
use crate::fit::error::FitError;
use std::path::Path;

/// Modes a preset keeps per object when none is asked for (`tactus fit --modes`, the pool's
/// `DEFAULT_COUNT`). Here because a recording's fit swells its modes only where a preset of that
/// many modes would get no dense field ([`fit_signal`]).
pub const DEFAULT_MODES: usize = 24;

/// Result of fitting one file.
#[derive(Debug, Clone)]
pub struct FileResult {
    /// File name.
    pub name: String,
    /// Sample rate.
    pub fs: f64,
    /// Extracted modes, strongest first (levels dB re full scale).
    pub modes: Vec<Mode>,
    /// The object's ringing modes as a preset pools them ([`ringing_modes`]), with the rings
    /// and swells their bands show ([`ring::with_rings`]).
    pub ringing: Vec<Mode>,
    /// Transient band fits to the energy [`FileResult::ringing`] leaves unexplained: the strike
    /// noise a preset's draws play with those modes.
    pub ringing_transient: Vec<Option<(f64, f64)>>,
    /// Transient band fits to the energy left unexplained by [`FileResult::ringing`] together
    /// with the recording's other counted partials (those a dense field plays,
    /// [`crate::fit::pool::density::fit_dense`]); `None` when the recording has no more peaks than
    /// ringing modes, or when it was fitted without `dense` ([`fit_signal`]).
    pub dense_transient: Option<DenseTransients>,
    /// Fitted attack time constant, s ([`extract::Extraction::attack_s`]).
    pub attack_s: f64,
    /// Transient band fits.
    pub transient: Vec<Option<(f64, f64)>>,
    /// ERB-band log-spectral distance of the resynthesis, dB.
    pub distance_db: f64,
    /// Note (e.g. stereo mixed to mono).
    pub note: String,
    /// The counted spectral peaks a dense mode field is fitted from ([`crate::fit::pool::density::fit_dense`]);
    /// empty when fitted without `dense` ([`fit_signal`]).
    pub dense: dense::Candidates,
    /// The recording ends before its sound has decayed (faded, cut or capped while ringing:
    /// [`crate::analysis::censoring`]): its decays are lower bounds on the object's, and the
    /// pooling lengthens them ([`crate::fit::pool::censored`]). From the manifest beside the file
    /// where it lists it ([`fit_file`]), else from the signal ([`fit_signal`]).
    pub censored: bool,
}

/// [`FileResult::dense_transient`]: the strike noise beside a dense field whose modes swell
/// with their bands' build-ups ([`dense::Candidates::swelling`]), and beside one whose
/// modes start at full level; the same when no band builds up.
#[derive(Debug, Clone)]
pub struct DenseTransients {
    /// Beside the partials with their build-ups.
    pub swelling: Vec<Option<(f64, f64)>>,
    /// Beside the partials without.
    pub flat: Vec<Option<(f64, f64)>>,
}

/// Extracts modes and transient from one recording and measures its resynthesis distance.
/// Errors are one line naming the file: unreadable or unusable audio, or a fit whose modes or
/// transient hold non-finite numbers (which would make the pooled preset invalid). `dense` as
/// for [`fit_signal`].
pub fn fit_file(path: &Path, dense: bool) -> anyhow::Result<FileResult> {
    let rec = audio::read_recording(path).map_err(|e| FitError::Unreadable(format!("{e:#}")))?;
    let r = fit_signal(
        &rec.samples,
        rec.sample_rate,
        &path.display().to_string(),
        rec.note,
        dense,
    );
    let finite_modes = r
        .modes
        .iter()
        .all(|m| m.freq_hz.is_finite() && m.level_db.is_finite() && m.decay_db_per_s.is_finite());
    if !finite_modes {
        return Err(FitError::NonFinite(format!(
            "{}: the extracted modes hold non-finite frequencies, levels or decays (near-DC or sub-audio content?)",
            path.display()
        ))
        .into());
    }
    if r.transient
        .iter()
        .chain(&r.ringing_transient)
        .flatten()
        .any(|(a, b)| !a.is_finite() || !b.is_finite())
    {
        return Err(FitError::NonFinite(format!(
            "{}: the fitted strike noise (transient) holds non-finite levels or decays",
            path.display()
        ))
        .into());
    }
    // The manifest, where it lists the file, knows the edit (a fade the envelope hides, a cap
    // applied before the file was written) better than the signal's end.
    let censored = crate::analysis::censoring::from_manifest_beside(path)
        .map_err(|e| FitError::Unreadable(format!("{e:#}")))?;
    Ok(FileResult {
        censored: censored.unwrap_or(r.censored),
        ..r
    })
}

/// As [`fit_file`] for a signal in memory. With `dense`, also what a dense mode field is fitted
/// from ([`FileResult::dense`], [`FileResult::dense_transient`]): every counted partial's band
/// decay over the whole ring, and the strike noise refitted beside those partials (about 30 % of
/// a cymbal recording's fit); without, those are left empty: a preset without dense fields never
/// reads them.
pub fn fit_signal(x: &[f64], fs: f64, name: &str, note: String, dense: bool) -> FileResult {
    let ex = extract::extract(x, fs, extract::MAX_MODES);
    let y: Vec<f64> = x[ex.onset..].iter().map(|v| v - ex.dc).collect();
    // Sub-audio and non-finite components are never modes. Strike noise stays in the
    // resynthesis (the transient's band noise, bounded to decay no faster than π·ERB, does not
    // reproduce a millisecond component; docs/model.md §3) and is left out when modes are
    // pooled into a preset.
    let (mut modes, strike_noise) = modes::split_modes(&ex.modes, fs, y.len());
    modes.extend(strike_noise);
    modes.sort_by(|a, b| b.level_db.total_cmp(&a.level_db));
    let modal = extract::synthesize(&modes, fs, y.len());
    let transient = transient::fit_transient_gap(&y, &modal, fs);
    let tr = bands::synthesize_transient(&transient, fs, y.len(), 1);
    let resynth: Vec<f64> = modal.iter().zip(&tr).map(|(a, b)| a + b).collect();
    let distance_db = bands::erb_log_spectral_distance(&y, &resynth, fs);
    if std::env::var_os("TACTUS_DEBUG_LSD").is_some() {
        eprintln!(
            "{name}: modal-only {:.2} dB, modes+transient {distance_db:.2} dB",
            bands::erb_log_spectral_distance(&y, &modal, fs)
        );
    }
    let (peaks, measured) = partials::peaks_and_partials(&y, fs);
    let pooled = ringing_modes(&modes, &measured, fs, y.len());
    // Swells only where a preset of the default count of modes would get no dense field: a
    // recording with more peaks holds partials in its modes' bands beside them.
    let dense_bound = dense::DENSE_MIN_PEAK_RATIO * DEFAULT_MODES.min(pooled.len()) as f64;
    let ringing = ring::with_rings(pooled, &y, fs, (peaks.len() as f64) < dense_bound);
    // The transient a preset plays with these modes fills what they leave: the strike noise
    // and the fast components left out of the pool as well as what the fit missed, but not what
    // rings on for more than twice the slowest mode's T60 (`fit_transient_gap_decaying`).
    let slowest = ringing
        .iter()
        .map(|m| {
            m.ring
                .map_or(m.decay_db_per_s, |r| r.decay_db_per_s.min(m.decay_db_per_s))
        })
        .fold(f64::INFINITY, f64::min);
    let slowest_gap = if slowest.is_finite() { 0.5 * slowest } else { 0.0 };
    let ringing_transient = transient::fit_transient_gap_decaying(
        &y,
        &extract::synthesize(&ringing, fs, y.len()),
        fs,
        slowest_gap,
        transient::GapDecay::Line,
    );
    // A draw with a dense field also plays the recording's other partials: the strike noise
    // that goes with it fills only what those leave too. Fitted to the ringing modes alone, a
    // cymbal's transient carries the wash the dense field already plays, so its draws had it
    // twice (China Cymbal draws counted 236 peaks, the transient's noise among them, against
    // the recordings' 203–223; 192 with this transient).
    let candidates = match dense {
        true => dense::candidates(peaks.len(), &measured, &y, fs),
        false => dense::Candidates::default(),
    };
    let beside = |swelling: bool| {
        let field: Vec<Mode> = ringing
            .iter()
            .copied()
            .chain(dense::uncovered(&candidates, &ringing).map(|p| match swelling {
                true => candidates.swelling(p),
                false => Mode { attack_s: 0.0, ..*p },
            }))
            .collect();
        transient::fit_transient_gap_decaying(
            &y,
            &extract::synthesize(&field, fs, y.len()),
            fs,
            slowest_gap,
            transient::GapDecay::EarlyShare,
        )
    };
    let dense_transient = (candidates.peaks > ringing.len()).then(|| {
        let flat = beside(false);
        let swelling = match candidates.band_rises.iter().any(|&r| r > 0.0) {
            true => beside(true),
            false => flat.clone(),
        };
        DenseTransients { swelling, flat }
    });
    FileResult {
        name: name.to_owned(),
        fs,
        ringing,
        ringing_transient,
        dense_transient,
        modes,
        attack_s: ex.attack_s,
        transient,
        distance_db,
        note,
        dense: candidates,
        censored: crate::analysis::censoring::from_signal(x, fs),
    }
}

/// A recording's ringing modes, as a preset pools them, from its extracted `components` and
/// its `measured` partials ([`partials::peaks_and_partials`]) of a signal of `n` samples:
///
/// 1. near-coincident copies, and copies whose spectral peaks overlap, are merged
///    ([`modes::consolidate_attack_free`], [`modes::unresolved`]);
/// 2. each measured partial that rings (no faster than [`ringing_decay_limit_db_per_s`])
///    replaces the merged component nearest to it within one track bin
///    ([`partials::partial_track_bin_hz`] of that signal), keeping that component's frequency and build-up,
///    or is added where there is none; other components within that bin are absorbed into it;
///    its decay is the measured one, and its level is set so that the mode's own track
///    carries the partial's measured energy;
/// 3. components decaying faster than [`ringing_decay_limit_db_per_s`] are left out.
///
/// Why step 2: the joint fit explains the waveform's first instants and ranks components by
/// onset level, so a weak partial that rings for a second (a marimba bar's 785 Hz partial,
/// 36 dB under its fundamental and ringing as long) may find no component, and a partial whose
/// onset the strike dominates gets that component's decay (a steel drum's 520 Hz partial rings
/// at 10 dB/s; the component there decays at 655 dB/s). Drawn from such modes, objects ring
/// shorter and with another decay-vs-frequency slope than the recordings, by the same
/// measure the evaluation applies to both (docs/model.md §3, "What a preset pools").
pub fn ringing_modes(components: &[Mode], measured: &[Mode], fs: f64, n: usize) -> Vec<Mode> {
    let mut merged = modes::consolidate_attack_free(components, modes::CONSOLIDATE_REL);
    let bin = partials::partial_track_bin_hz(fs, n);
    let mut taken = vec![false; merged.len()];
    let mut absorbed = vec![false; merged.len()];
    let mut added = Vec::new();
    for p in measured {
        // A track with another partial in its main lobe (Hann: ±2 bins) measures their
        // beating sum, not either partial: there the joint fit, which separates them, stands.
        let crowded = measured
            .iter()
            .any(|q| !std::ptr::eq(p, q) && (q.freq_hz - p.freq_hz).abs() < 2.0 * bin);
        if crowded || !(p.decay_db_per_s <= ringing_decay_limit_db_per_s(p.freq_hz)) {
            continue;
        }
        let near = |m: &Mode| (m.freq_hz - p.freq_hz).abs() <= bin;
        let nearest = (0..merged.len())
            .filter(|&i| near(&merged[i]) && !taken[i])
            .min_by(|&a, &b| {
                (merged[a].freq_hz - p.freq_hz)
                    .abs()
                    .total_cmp(&(merged[b].freq_hz - p.freq_hz).abs())
            });
        let mut mode = match nearest {
            Some(i) => merged[i],
            None => Mode {
                freq_hz: p.freq_hz,
                level_db: 0.0,
                decay_db_per_s: 0.0,
                phase: 0.0,
                attack_s: 0.0,
                ring: None,
            },
        };
        mode.decay_db_per_s = p.decay_db_per_s;
        mode.level_db = 0.0;
        mode.phase = 0.0;
        let Some(level_db) = level_for_energy(&mode, p.freq_hz, energy_db(p), fs, n) else {
            continue;
        };
        mode.level_db = level_db;
        for i in 0..merged.len() {
            if near(&merged[i]) && !taken[i] {
                absorbed[i] = true;
            }
        }
        match nearest {
            Some(i) => {
                merged[i] = mode;
                taken[i] = true;
                absorbed[i] = false;
            }
            None => added.push(mode),
        }
    }
    let mut out: Vec<Mode> = merged
        .into_iter()
        .zip(&absorbed)
        .filter(|(_, a)| !**a)
        .map(|(m, _)| m)
        .chain(added)
        .filter(|m| m.decay_db_per_s <= ringing_decay_limit_db_per_s(m.freq_hz))
        .collect();
    out.sort_by(|a, b| energy_db(b).total_cmp(&energy_db(a)));
    out
}

/// Fastest decay, dB/s, of a mode that a preset pools at `freq_hz`: the slower of strike noise's
/// bound ([`modes::max_mode_decay_db_per_s`]) and a T60 of one frame of the partials' tracks
/// ([`partials::PARTIAL_TRACK_FRAME_S`], ~40 ms, about the ear's temporal integration). Why the
/// frame: above ~1 kHz a one-ERB band may die within a few milliseconds, so the strike bound
/// passes components with T60s of 5–40 ms; such a component is heard (and measured) as part of
/// the click, not as a partial that rings, but among an object's 24 drawn modes it stands out as
/// one where the recording shows no prominent spectral peak. The transient that goes with the pooled modes
/// takes their energy up ([`fit_signal`]).
pub fn ringing_decay_limit_db_per_s(freq_hz: f64) -> f64 {
    modes::max_mode_decay_db_per_s(freq_hz).min(60.0 / partials::PARTIAL_TRACK_FRAME_S)
}

/// The level (dB) at which `mode` (its level ignored) gives a track at `track_hz` of
/// `energy_db` ([`partials::partials`]' energy) in a signal of `n` samples: the mode alone is
/// synthesised at 0 dB over as many samples and tracked the same way, so the track's window,
/// hop and span cancel. `None` when the mode's own track does not decay.
pub(crate) fn level_for_energy(mode: &Mode, track_hz: f64, energy_db: f64, fs: f64, n: usize) -> Option<f64> {
    let unit = Mode {
        level_db: 0.0,
        ..*mode
    };
    let y = extract::synthesize(&[unit], fs, n.min((partials::MODE_SPAN_S * fs) as usize));
    let tracked = partials::partials(&y, fs, &[track_hz]);
    let own = tracked.first()?;
    Some(energy_db - signal::energy_db(own))
}
