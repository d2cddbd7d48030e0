//! Error measures of the benchmark: whole-render ERB-band distance and the worst frame.

use super::*;
use realfft::RealFftPlanner;

/// The bench's error measure: [`crate::perceptual::erb_log_spectral_distance_db`] with
/// [`LSD_BANDS`] bands and a floor [`LSD_FLOOR_DB`] below the loudest reference band.
pub fn erb_lsd_db(reference: &[f64], test: &[f64], fs: f64) -> f64 {
    crate::perceptual::erb_log_spectral_distance_db(reference, test, fs, LSD_BANDS, LSD_FLOOR_DB)
}

/// The [`LSD_BANDS`] ERB band centres of the error measures: 50 Hz … min(16 kHz, 0.45·fs).
pub(super) fn lsd_centres(fs: f64) -> Vec<f64> {
    let mut centres = Vec::new();
    erb_centres(
        LSD_BANDS,
        crate::perceptual::LOW_HZ,
        crate::perceptual::high_hz(fs),
        &mut centres,
    );
    centres
}

/// Frame length of [`frame_erb_error_db`], samples at 48 kHz (85 ms; hop half of it).
pub const FRAME_ERROR_LEN: usize = 4096;

/// Playback level assumed by [`frame_erb_error_db`]: a full-scale sine plays at this SPL (the
/// level the default quality 60 assumes for its threshold-of-hearing culling).
pub const FRAME_ERROR_FULL_SCALE_DB_SPL: f64 = 110.0;

/// Time-resolved error: the worst frame's RMS over the ERB bands of the level difference, in dB.
/// Frames of [`FRAME_ERROR_LEN`] samples (Hann, hop half a frame); each band's level is its
/// mean-square in dB SPL with a full-scale sine at [`FRAME_ERROR_FULL_SCALE_DB_SPL`], floored at
/// the threshold of hearing at the band centre (`modal::hearing_threshold_db_spl`), so what
/// neither render makes audible counts as equal. Unlike [`erb_lsd_db`] over the whole render, a
/// tail cut while still above the threshold shows in its frames. No masking across bands is
/// modelled, so a weak component that a louder band would mask still counts: an upper bound of
/// the audible error.
pub fn frame_erb_error_db(reference: &[f64], test: &[f64], fs: f64) -> f64 {
    let n = reference.len().min(test.len());
    let len = FRAME_ERROR_LEN;
    if n < len {
        return 0.0;
    }
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(len);
    let window: Vec<f64> = (0..len)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / len as f64).cos())
        .collect();
    let w2: f64 = window.iter().map(|w| w * w).sum();
    let centres = lsd_centres(fs);
    let floors: Vec<f64> = centres
        .iter()
        .map(|&f| crate::engine::modal::hearing_threshold_db_spl(f))
        .collect();
    let bin_hz = fs / len as f64;
    let (mut buf, mut spec) = (fft.make_input_vec(), fft.make_output_vec());
    let mut levels = |x: &[f64]| -> Vec<f64> {
        for ((b, &v), w) in buf.iter_mut().zip(x).zip(&window) {
            *b = v * w;
        }
        fft.process(&mut buf, &mut spec).expect("fft sizes");
        let p: Vec<f64> = spec.iter().map(|c| c.norm_sqr()).collect();
        // One-sided bins: a component's mean-square is 2·Σ|X|² / (N·Σw²); a full-scale sine's is 1/2.
        centres
            .iter()
            .zip(&floors)
            .map(|(&f, &floor)| {
                let ms = 2.0 * crate::perceptual::erb_band_power(&p, f, bin_hz) / (len as f64 * w2);
                (FRAME_ERROR_FULL_SCALE_DB_SPL + 10.0 * (ms / 0.5 + 1e-300).log10()).max(floor)
            })
            .collect()
    };
    let mut worst = 0.0f64;
    let mut start = 0;
    while start + len <= n {
        let r = levels(&reference[start..start + len]);
        let t = levels(&test[start..start + len]);
        let ss: f64 = r.iter().zip(&t).map(|(a, b)| (a - b).powi(2)).sum();
        worst = worst.max((ss / r.len() as f64).sqrt());
        start += len / 2;
    }
    worst
}
