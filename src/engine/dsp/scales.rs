//! Perceptual frequency scales and the threshold of hearing: ERB rate and bandwidth (Glasberg &
//! Moore 1990, used for the transient's bands and the error measures), Bark (Traunmüller 1990,
//! the masking grid) and Terhardt's threshold in quiet (culling of inaudible modes and bands).

/// ERB-rate (Glasberg & Moore 1990) of a frequency in Hz.
pub fn erb_rate(f_hz: f64) -> f64 {
    21.4 * (1.0 + 0.00437 * f_hz).log10()
}

/// Inverse of [`erb_rate`].
pub fn erb_rate_to_hz(e: f64) -> f64 {
    (10f64.powf(e / 21.4) - 1.0) / 0.00437
}

/// Equivalent rectangular bandwidth in Hz at `f_hz`.
pub fn erb_bandwidth_hz(f_hz: f64) -> f64 {
    24.7 * (1.0 + 0.00437 * f_hz)
}

/// `n` band centres equally spaced on the ERB-rate scale from `low_hz` to `high_hz`.
pub fn erb_centres(n: usize, low_hz: f64, high_hz: f64, out: &mut Vec<f64>) {
    out.clear();
    let (a, b) = (erb_rate(low_hz), erb_rate(high_hz));
    for i in 0..n {
        let t = if n > 1 { i as f64 / (n - 1) as f64 } else { 0.0 };
        out.push(erb_rate_to_hz(a + t * (b - a)));
    }
}

/// The threshold of hearing in quiet at `freq_hz`, dB SPL: Terhardt's (1979) approximation of
/// the ISO 226 curve, `3.64·f^−0.8 − 6.5·e^{−0.6(f−3.3)²} + 10^−3·f^4` (f in kHz), capped at
/// 40 dB SPL (Terhardt's f⁴ term overshoots above 14 kHz; young listeners hear 16 kHz at
/// about 40 dB SPL, so the cap keeps culling conservative there). Frequencies below 20 Hz
/// use the 20 Hz value.
pub fn hearing_threshold_db_spl(freq_hz: f64) -> f64 {
    let f = (freq_hz.max(20.0)) / 1000.0;
    let t = 3.64 * f.powf(-0.8) - 6.5 * (-0.6 * (f - 3.3) * (f - 3.3)).exp() + 1e-3 * f.powi(4);
    if t.is_finite() {
        t.min(40.0)
    } else {
        40.0
    }
}

/// [`hearing_threshold_db_spl`] as a power ratio to 0 dB SPL.
pub fn hearing_threshold_power(freq_hz: f64) -> f64 {
    10f64.powf(hearing_threshold_db_spl(freq_hz) / 10.0)
}

/// Critical-band rate in Bark at `freq_hz` (Traunmüller 1990: `26.81·f/(1960 + f) − 0.53`).
pub fn bark(freq_hz: f64) -> f64 {
    26.81 * freq_hz / (1960.0 + freq_hz) - 0.53
}
