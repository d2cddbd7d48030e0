//! The one perceptual distance between two renders or recordings, shared by `tactus bench`
//! (error of a culled render against the unculled one) and `tactus fit` (a resynthesis against
//! its recording).

use crate::engine::dsp::scales::{erb_bandwidth_hz, erb_centres};
use realfft::RealFftPlanner;

/// Lowest band centre of [`erb_log_spectral_distance_db`], Hz.
pub const LOW_HZ: f64 = 50.0;

/// Highest band centre of [`erb_log_spectral_distance_db`] for a signal sampled at `fs`, Hz:
/// 16 kHz (the top of what the model renders and most listeners hear), or 0.45·fs below
/// 35.6 kHz so a low-rate signal keeps every band inside what it holds.
pub fn high_hz(fs: f64) -> f64 {
    16_000f64.min(0.45 * fs)
}

/// ERB-band log-spectral distance in dB: how far apart two signals' long-term spectra are on an
/// auditory frequency scale, blind to phase and time structure. The power spectrum of each whole
/// signal (the first `min(len)` samples, zero-padded to a power of two) is summed into `bands`
/// bands one ERB wide, centred at ERB-rate-spaced frequencies from [`LOW_HZ`] to
/// [`high_hz`]`(fs)`; each band's energy in dB is floored at `range_db` below the loudest
/// reference band (what lies further down in both signals counts as equal); the result is the
/// RMS over the bands of the dB difference. 0 = identical band energies; a uniform gain of
/// g dB gives |g| dB where both are above the floor.
pub fn erb_log_spectral_distance_db(
    reference: &[f64],
    test: &[f64],
    fs: f64,
    bands: usize,
    range_db: f64,
) -> f64 {
    let n = reference.len().min(test.len());
    if n < 2 || bands == 0 {
        return 0.0;
    }
    let nfft = n.next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let power = |x: &[f64]| -> Vec<f64> {
        let mut buf = vec![0.0; nfft];
        buf[..n].copy_from_slice(&x[..n]);
        let mut s = fft.make_output_vec();
        fft.process(&mut buf, &mut s).expect("fft sizes");
        s.iter().map(|c| c.norm_sqr()).collect()
    };
    let (pr, pt) = (power(reference), power(test));
    let mut centres = Vec::new();
    erb_centres(bands, LOW_HZ, high_hz(fs), &mut centres);
    let bin_hz = fs / nfft as f64;
    let er: Vec<f64> = centres
        .iter()
        .map(|&f| 10.0 * (erb_band_power(&pr, f, bin_hz) + 1e-300).log10())
        .collect();
    let et: Vec<f64> = centres
        .iter()
        .map(|&f| 10.0 * (erb_band_power(&pt, f, bin_hz) + 1e-300).log10())
        .collect();
    let floor = er.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - range_db;
    let ss: f64 = er
        .iter()
        .zip(&et)
        .map(|(r, t)| (r.max(floor) - t.max(floor)).powi(2))
        .sum();
    (ss / er.len() as f64).sqrt()
}

/// Power of the one-ERB-wide band around `fc` in a one-sided power spectrum `p` with `bin_hz`
/// bins (DC excluded; at least one bin).
pub fn erb_band_power(p: &[f64], fc: f64, bin_hz: f64) -> f64 {
    let bw = erb_bandwidth_hz(fc);
    let a = ((fc - bw / 2.0) / bin_hz).floor().max(1.0) as usize;
    let b = (((fc + bw / 2.0) / bin_hz).ceil() as usize)
        .min(p.len() - 1)
        .max(a);
    p[a..=b].iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone(amp: f64, f: f64, n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| amp * (std::f64::consts::TAU * f * i as f64 / 48_000.0).sin())
            .collect()
    }

    #[test]
    fn gain_shows_as_its_db_and_identity_as_zero() {
        let n = 1 << 14;
        let x: Vec<f64> = (0..n)
            .map(|i| tone(1.0, 300.0, n)[i] + tone(0.5, 2_000.0, n)[i])
            .collect();
        assert_eq!(erb_log_spectral_distance_db(&x, &x, 48_000.0, 30, 60.0), 0.0);
        // A 6 dB gain with a 200 dB range: every band differs by 6 dB.
        let y: Vec<f64> = x.iter().map(|v| v * 2.0).collect();
        let d = erb_log_spectral_distance_db(&x, &y, 48_000.0, 30, 200.0);
        assert!((d - 20.0 * 2f64.log10()).abs() < 1e-9, "{d}");
        // A missing component counts, but only down to the floor.
        let lone = tone(1.0, 300.0, n);
        let d60 = erb_log_spectral_distance_db(&x, &lone, 48_000.0, 30, 60.0);
        let d20 = erb_log_spectral_distance_db(&x, &lone, 48_000.0, 30, 20.0);
        assert!(d60 > d20 && d20 > 0.0, "{d60} {d20}");
    }
}
