//! Whether a recording's decay is censored (docs/evaluation.md, "Censored decays"): a recording
//! that ends before its sound has decayed by [`RANG_OUT_DB`] — faded by an editor, cut or capped
//! while still ringing — gives decay features (T60, EDT, the partials' ring times) that are lower
//! bounds on the object's, not measurements of it. Its manifest says so where it lists the file
//! ([`from_manifest`]); otherwise the signal does ([`from_signal`]), by the same rules as the
//! kits' manifest's `end_condition`.

use crate::analysis::manifest::Manifest;
use std::path::Path;

/// A recording whose envelope fell this far below its peak (dB) before it ended or was faded
/// has rung out: its T60 was read before the edit.
pub const RANG_OUT_DB: f64 = -60.0;
/// An end stretch flatter than this (dB/s) sits on the noise floor: the decay is over.
const FLOOR_SLOPE_DB_PER_S: f64 = -2.0;
/// A flat end louder than this (dB re peak) is no noise floor but a wash that holds (a cymbal
/// capped at 6 s while it sustains at −25 dB).
const LOUD_END_DB: f64 = -35.0;
/// Envelope frames: 10 ms RMS every 2.5 ms (the kits' manifest's).
const FRAME_S: f64 = 0.010;
const HOP_S: f64 = 0.0025;
/// Left off the end of a file before judging it: the 5 ms fade-out the kits' processing puts on
/// every file.
const END_GUARD_S: f64 = 0.005;
/// The stretch a fade is looked for in, s: an editor's fade bends the last part of the envelope
/// far below its trend.
const FADE_WINDOW_S: f64 = 0.100;
/// How far below the trend's line a fade ends, at least, dB.
const FADE_DROP_DB: f64 = 6.0;

/// The censoring verdict of a manifest row from its `end_condition` (both manifests' wordings)
/// and `end_level_db_re_peak`; `None` when the row says nothing of its end. Censored: a fade
/// (kits' "fade found", DEV "editor fade-out") unless the natural decay reached [`RANG_OUT_DB`]
/// before it, or an end "while still decaying" (a cut or a cap) above [`RANG_OUT_DB`]. Not
/// censored: a decay into the noise floor.
pub fn from_manifest(end_condition: &str, end_level_db: Option<f64>) -> Option<bool> {
    let end = end_condition.trim().to_lowercase().replace('−', "-");
    if end.is_empty() {
        return None;
    }
    let number_after = |key: &str| -> Option<f64> {
        let at = end.find(key)? + key.len();
        end[at..].split_whitespace().next()?.parse().ok()
    };
    if end.contains("noise floor") {
        return Some(false);
    }
    if end.contains("fade") {
        let reached = number_after("natural decay reached ");
        return Some(!reached.is_some_and(|l| l <= RANG_OUT_DB));
    }
    if end.contains("still decaying") {
        let level = end_level_db.or_else(|| number_after("last level "));
        return Some(!level.is_some_and(|l| l <= RANG_OUT_DB));
    }
    None
}

/// The verdict the `manifest.csv` beside `path` gives it ([`from_manifest`]); `None` when no
/// manifest lists it with an end condition. Errors name an unreadable manifest.
pub fn from_manifest_beside(path: &Path) -> anyhow::Result<Option<bool>> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let Some(m) = Manifest::of_folder(dir)? else {
        return Ok(None);
    };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
    let verdict = m
        .rows()
        .find(|r| Some(r.file()) == name.as_deref())
        .and_then(|r| from_manifest(r.get("end_condition"), r.get("end_level_db_re_peak").parse().ok()));
    Ok(verdict)
}

/// Whether the signal `x` (at `fs`) ends before its sound has decayed: its envelope (10 ms RMS,
/// dB re its loudest frame, the last 5 ms left off) ends above [`RANG_OUT_DB`] and is either
/// still falling at the end (the last quarter after the peak, 0.1–1.5 s, steeper than 2 dB/s:
/// not on a noise floor) or louder than −35 dB re peak (a wash that holds, not a floor), or it
/// is bent down by a fade (its last 100 ms falling faster than 60 dB/s and twice the falling
/// trend before them, ending 6 dB or more below the trend's line) from a level above
/// [`RANG_OUT_DB`]. On the DEV and kit recordings it agrees with the manifests on 81 of 86
/// censored and 23 of 32 rung-out files (`tests/integration/censoring.rs`): most of the rest
/// are capped cymbals the kits' manifest judges by the source beyond the cap.
pub fn from_signal(x: &[f64], fs: f64) -> bool {
    let (frame, hop) = (
        (FRAME_S * fs).round() as usize,
        (HOP_S * fs).round().max(1.0) as usize,
    );
    let guard = (END_GUARD_S * fs).round() as usize;
    if frame == 0 || x.len() < frame + guard + 8 * hop {
        return false;
    }
    let usable = &x[..x.len() - guard];
    let env: Vec<f64> = (0..=(usable.len() - frame) / hop)
        .map(|i| {
            let w = &usable[i * hop..i * hop + frame];
            10.0 * (w.iter().map(|v| v * v).sum::<f64>() / frame as f64 + 1e-30).log10()
        })
        .collect();
    let top = env.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let db: Vec<f64> = env.iter().map(|v| v - top).collect();
    let peak = db.iter().position(|&v| v == 0.0).unwrap_or(0);
    let t = |i: usize| i as f64 * HOP_S;
    let n = db.len();
    let span = ((n - peak) as f64 * HOP_S * 0.25).clamp(0.1, 1.5);
    let start = n.saturating_sub((span / HOP_S) as usize).max(peak);
    let fade_frames = ((FADE_WINDOW_S / HOP_S) as usize).min((n - start) / 2);
    if n - start < 8 || fade_frames < 2 {
        return false;
    }
    let slope_of = |a: usize, b: usize| {
        let (ts, ls): (Vec<f64>, Vec<f64>) = (a..b).map(|i| (t(i), db[i])).unzip();
        crate::analysis::signal::line_fit(&ts, &ls)
    };
    let end_level = db[n - 4..].iter().sum::<f64>() / 4.0;
    let trend_end = n - fade_frames;
    let (trend, icpt) = slope_of(start, trend_end);
    let (last, _) = slope_of(trend_end, n);
    let below_trend = trend * t(n - 1) + icpt - end_level;
    let faded = trend < 0.0 && last < -60.0 && last < 2.0 * trend && below_trend >= FADE_DROP_DB;
    if faded {
        // Where the fade starts the trend's line still holds: the level the decay had reached.
        return trend * t(trend_end) + icpt > RANG_OUT_DB;
    }
    let (whole, _) = slope_of(start, n);
    end_level > RANG_OUT_DB && (whole < FLOOR_SLOPE_DB_PER_S || end_level > LOUD_END_DB)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A decaying tone of `t60` seconds over `secs`, over white-ish noise at `floor_db` re its
    /// start, faded linearly to silence over its last `fade_s` seconds.
    fn tone(fs: f64, secs: f64, t60: f64, floor_db: f64, fade_s: f64) -> Vec<f64> {
        let n = (secs * fs) as usize;
        let mut seed = 12345u64;
        (0..n)
            .map(|i| {
                let t = i as f64 / fs;
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let noise = ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 3.46;
                let s = 10f64.powf(-3.0 * t / t60) * (std::f64::consts::TAU * 440.0 * t).sin();
                let g = ((secs - t) / fade_s).clamp(0.0, 1.0);
                g * (s + noise * 10f64.powf(floor_db / 20.0) * std::f64::consts::FRAC_1_SQRT_2)
            })
            .collect()
    }

    /// Both manifests' wordings, and the −60 dB rule for fades after the decay and quiet cuts.
    #[test]
    fn manifest_wordings() {
        assert_eq!(from_manifest("decays to noise floor", None), Some(false));
        assert_eq!(
            from_manifest("decays into recording noise floor (~-74 dB re peak)", None),
            Some(false)
        );
        assert_eq!(from_manifest("fade found", None), Some(true));
        assert_eq!(
            from_manifest(
                "editor fade-out from ~1.434 s (natural decay reached -63 dB re peak before it)",
                None
            ),
            Some(false)
        );
        assert_eq!(
            from_manifest(
                "editor fade-out from ~2.878 s (natural decay reached -45 dB re peak before it)",
                None
            ),
            Some(true)
        );
        assert_eq!(
            from_manifest("ends while still decaying", Some(-21.0)),
            Some(true)
        );
        assert_eq!(
            from_manifest("ends while still decaying", Some(-63.0)),
            Some(false)
        );
        assert_eq!(
            from_manifest(
                "sample ends while still decaying (last level -39 dB re peak)",
                None
            ),
            Some(true)
        );
        assert_eq!(
            from_manifest(
                "sample ends while still decaying (last level −61 dB re peak)",
                None
            ),
            Some(false)
        );
        assert_eq!(from_manifest("", None), None);
        assert_eq!(from_manifest("something else", None), None);
    }

    /// A tone cut while loud, or faded while loud, is censored; one that decays into its noise
    /// floor, or is faded after it got there, is not.
    #[test]
    fn signal_tells_a_cut_or_fade_from_a_decay_into_the_floor() {
        let fs = 16_000.0;
        assert!(
            from_signal(&tone(fs, 1.0, 3.0, -80.0, 0.001), fs),
            "cut at -20 dB"
        );
        assert!(
            from_signal(&tone(fs, 1.5, 3.0, -80.0, 0.15), fs),
            "faded at -30 dB"
        );
        assert!(
            !from_signal(&tone(fs, 2.0, 0.5, -70.0, 0.001), fs),
            "rang into the floor"
        );
        assert!(
            !from_signal(&tone(fs, 2.0, 0.5, -70.0, 0.15), fs),
            "faded on the floor"
        );
        assert!(!from_signal(&[0.0; 10], fs), "too short to tell");
    }
}
