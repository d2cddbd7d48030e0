//! The transient's ERB-spaced noise bands (Traer et al. 2019 eq. 3, docs/model.md §2): their
//! centres, band-limited noise under each band's envelope, band energies of a signal, the
//! leakage of each band into its neighbours, and the ERB-band distance `tactus fit` reports.

use crate::engine::dsp::scales::{erb_bandwidth_hz, erb_centres};
use realfft::RealFftPlanner;

/// Transient bands (Traer: 30) and their centre range in Hz.
pub const BANDS: usize = 30;
/// Lowest band centre, Hz.
pub const BAND_LOW_HZ: f64 = 50.0;
/// Highest band centre, Hz.
pub const BAND_HIGH_HZ: f64 = 16_000.0;
/// Synthesises the transient of [`fit_transient_gap`](crate::fit::recording::transient::fit_transient_gap): seeded band noise, each band under its
/// envelope and scaled to its expected energy (the sum of [`transient_band_signals`], each at
/// its level).
pub fn synthesize_transient(bands: &[Option<(f64, f64)>], fs: f64, n: usize, seed: u64) -> Vec<f64> {
    let decays: Vec<Option<f64>> = bands.iter().map(|b| b.map(|(_, d)| d)).collect();
    let mut out = vec![0.0; n];
    for (b, s) in bands.iter().zip(transient_band_signals(&decays, fs, n, seed)) {
        let (Some((lvl, _)), Some(s)) = (b, s) else {
            continue;
        };
        let g = 10f64.powf(lvl / 20.0);
        for (o, v) in out.iter_mut().zip(&s) {
            *o += g * v;
        }
    }
    out
}

/// The unit-level (0 dB) band signals [`synthesize_transient`] sums, `n` samples each: one seeded
/// white noise, band `i` its FFT bins within the ERB band (`in_band`) under the envelope of
/// decay `decays[i]` dB/s; `None` where `decays[i]` is.
pub fn transient_band_signals(decays: &[Option<f64>], fs: f64, n: usize, seed: u64) -> Vec<Option<Vec<f64>>> {
    use rand::{RngExt, SeedableRng};
    let mut centres = Vec::new();
    erb_centres(BANDS, BAND_LOW_HZ, BAND_HIGH_HZ, &mut centres);
    let nfft = n.next_power_of_two().max(2);
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(nfft);
    let inv = planner.plan_fft_inverse(nfft);
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let mut noise: Vec<f64> = (0..nfft).map(|_| rng.random::<f64>() - 0.5).collect();
    let mut spec = fwd.make_output_vec();
    fwd.process(&mut noise, &mut spec).expect("fft sizes");
    let bin_hz = fs / nfft as f64;
    decays
        .iter()
        .enumerate()
        .map(|(i, dec)| {
            let dec = (*dec)?;
            let fc = centres[i];
            let bw = erb_bandwidth_hz(fc);
            let mut s = vec![realfft::num_complex::Complex::new(0.0, 0.0); spec.len()];
            for (k, v) in s.iter_mut().enumerate() {
                if in_band(k as f64 * bin_hz, fc, bw) {
                    *v = spec[k];
                }
            }
            let mut band = vec![0.0; nfft];
            inv.process(&mut s, &mut band).expect("fft sizes");
            // The draw is scaled so that its energy under the envelope is the band's expected
            // energy, Σ env²: a band shorter than 1/ERB holds only a few degrees of freedom, and
            // a plain draw's energy in it is off by several dB (an exponential variable at the
            // limit), which the resynthesis distance then charged to the fit.
            let env = band_envelope(dec, bw, fs, n);
            let drawn: f64 = band.iter().zip(&env).map(|(v, e)| (v * e).powi(2)).sum();
            let expected: f64 = env.iter().map(|e| e * e).sum();
            if !(drawn > 0.0) {
                return None;
            }
            let gain = (expected / drawn).sqrt();
            Some(env.iter().zip(&band).map(|(e, v)| v * gain * e).collect())
        })
        .collect()
}

/// Whether `synthesize_transient` keeps the FFT bin at `f` Hz in the band centred `fc`, `bw` wide
/// (and `transient_leakage` counts it).
fn in_band(f: f64, fc: f64, bw: f64) -> bool {
    (f - fc).abs() <= bw / 2.0
}

/// Amplitude envelope of a unit-level transient band of bandwidth `bw` Hz: the decay
/// `10^(−decay·t/20)` (dB/s) times the rise `1 − e^{−π·bw·t}`, for `n` samples at `fs`. Why the
/// rise: the engine's bands are one-pole filters of 1 ERB bandwidth (`engine::transient`), whose
/// output power builds up as `1 − e^{−2π·bw·t}`, i.e. over ~1/(π·bw); a band that starts at full
/// level instead has a 1/f² spectral skirt that overfills the weak bands 5–15 kHz away.
pub(crate) fn band_envelope(decay: f64, bw: f64, fs: f64, n: usize) -> Vec<f64> {
    let r = 10f64.powf(-decay / (20.0 * fs));
    let q = (-std::f64::consts::PI * bw / fs).exp();
    let (mut g, mut h) = (1.0, 1.0);
    (0..n)
        .map(|_| {
            let v = g * (1.0 - h);
            g *= r;
            h *= q;
            v
        })
        .collect()
}

/// One-sided spectrum of `x` zero-padded to the length of the forward transform `fft`.
pub(crate) fn padded_spectrum(
    fft: &dyn realfft::RealToComplex<f64>,
    x: &[f64],
) -> Vec<realfft::num_complex::Complex<f64>> {
    let mut buf = vec![0.0; fft.len()];
    buf[..x.len()].copy_from_slice(x);
    let mut s = fft.make_output_vec();
    fft.process(&mut buf, &mut s).expect("fft sizes");
    s
}

/// One-sided FFT bins `a..=b` of each of the [`BANDS`] ERB bands (centres
/// [`BAND_LOW_HZ`]…`high_hz`) for an `nfft`-point transform at `fs`; `None` for bands above
/// 0.49·fs. With `high_hz` = [`BAND_HIGH_HZ`]: the transient model's bands; with
/// [`analysis_high_hz`]: the bands [`erb_log_spectral_distance`] judges a recording in.
pub(crate) fn band_bins(fs: f64, nfft: usize, high_hz: f64) -> Vec<Option<(usize, usize)>> {
    let mut centres = Vec::new();
    erb_centres(BANDS, BAND_LOW_HZ, high_hz, &mut centres);
    let bin_hz = fs / nfft as f64;
    let last = nfft / 2;
    centres
        .iter()
        .map(|&fc| {
            if fc >= 0.49 * fs {
                return None;
            }
            let bw = erb_bandwidth_hz(fc);
            let a = ((fc - bw / 2.0) / bin_hz).floor().max(1.0) as usize;
            let b = (((fc + bw / 2.0) / bin_hz).ceil() as usize).min(last).max(a);
            Some((a, b))
        })
        .collect()
}

/// Energy (Σ x², Parseval on the one-sided spectrum of the whole signal) in each of the
/// [`BANDS`] ERB bands of the transient model (`band_bins`); 0 for bands above 0.49·fs.
pub fn band_energies(x: &[f64], fs: f64) -> Vec<f64> {
    band_energies_up_to(x, fs, BAND_HIGH_HZ)
}

/// As [`band_energies`] in the [`BANDS`] ERB bands centred [`BAND_LOW_HZ`]…`high_hz`.
pub fn band_energies_up_to(x: &[f64], fs: f64, high_hz: f64) -> Vec<f64> {
    let n = x.len();
    let nfft = n.next_power_of_two().max(2);
    let mut planner = RealFftPlanner::<f64>::new();
    let s = padded_spectrum(&*planner.plan_fft_forward(nfft), x);
    band_bins(fs, nfft, high_hz)
        .iter()
        .map(|bins| {
            bins.map_or(0.0, |(a, b)| {
                2.0 / nfft as f64 * s[a..=b].iter().map(|c| c.norm_sqr()).sum::<f64>()
            })
        })
        .collect()
}

/// Expected band energies ([`band_energies`]) of one unit-level transient band
/// ([`synthesize_transient`]) of `n` samples: row `i` is band `i` decaying at `decays[i]` dB/s
/// (`None`: a zero row). The envelope (`band_envelope`) spreads the band's flat spectrum into
/// its neighbours (a fast decay by up to several bands): the expected power spectrum is the band's
/// indicator convolved with the envelope's power spectrum, scaled to the envelope's energy
/// `Σ_t env(t)²`. Expected, not one noise draw's, so a fit with it does not tune the levels to
/// one realisation. Columns: the bands centred [`BAND_LOW_HZ`]…`high_hz` ([`band_energies_up_to`]).
pub fn transient_leakage(decays: &[Option<f64>], fs: f64, n: usize, high_hz: f64) -> Vec<Vec<f64>> {
    let nfft = n.next_power_of_two().max(2);
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(nfft);
    let inv = planner.plan_fft_inverse(nfft);
    let bins = band_bins(fs, nfft, high_hz);
    let spectrum = |x: &[f64]| padded_spectrum(&*fwd, x);
    let mut centres = Vec::new();
    erb_centres(BANDS, BAND_LOW_HZ, BAND_HIGH_HZ, &mut centres);
    let bin_hz = fs / nfft as f64;
    decays
        .iter()
        .zip(&centres)
        .map(|(decay, fc)| {
            let Some(decay) = decay else {
                return vec![0.0; BANDS];
            };
            let mut env = band_envelope(*decay, erb_bandwidth_hz(*fc), fs, n);
            env.resize(nfft, 0.0);
            let energy: f64 = env.iter().map(|v| v * v).sum();
            // |ENV(k)|² on the whole circle (even), and the band's two-sided indicator.
            let half: Vec<f64> = spectrum(&env).iter().map(|c| c.norm_sqr()).collect();
            let mut pow = vec![0.0; nfft];
            let mut ind = vec![0.0; nfft];
            for k in 0..=nfft / 2 {
                pow[k] = half[k];
                pow[(nfft - k) % nfft] = half[k];
            }
            // The bins `synthesize_transient` keeps.
            let bw = erb_bandwidth_hz(*fc);
            for k in 0..=nfft / 2 {
                if in_band(k as f64 * bin_hz, *fc, bw) {
                    ind[k] = 1.0;
                    ind[(nfft - k) % nfft] = 1.0;
                }
            }
            // Circular convolution by FFT; both inputs real and even, so is the result.
            let (sp, si) = (spectrum(&pow), spectrum(&ind));
            let mut prod: Vec<_> = sp.iter().zip(&si).map(|(x, y)| x * y).collect();
            prod[0].im = 0.0;
            prod[nfft / 2].im = 0.0;
            let mut conv = vec![0.0; nfft];
            inv.process(&mut prod, &mut conv).expect("fft sizes");
            let total: f64 = conv.iter().map(|v| v.max(0.0)).sum();
            if !(total > 0.0) {
                return vec![0.0; BANDS];
            }
            bins.iter()
                .map(|bj| {
                    bj.map_or(0.0, |(aj, bjj)| {
                        2.0 * energy * conv[aj..=bjj].iter().map(|v| v.max(0.0)).sum::<f64>() / total
                    })
                })
                .collect()
        })
        .collect()
}

/// Highest ERB centre, Hz, of the bands a signal sampled at `fs` is judged in: 16 kHz, or
/// 0.45·fs below 35.6 kHz, so that a low-rate recording still has 30 bands over what it holds.
pub fn analysis_high_hz(fs: f64) -> f64 {
    BAND_HIGH_HZ.min(0.45 * fs)
}

/// The fit's distance between a recording and its resynthesis:
/// [`crate::perceptual::erb_log_spectral_distance_db`] in the [`BANDS`] bands of the transient
/// model, with a 60 dB range (a recording's noise floor lies 60–70 dB under its strongest band).
pub fn erb_log_spectral_distance(reference: &[f64], test: &[f64], fs: f64) -> f64 {
    crate::perceptual::erb_log_spectral_distance_db(reference, test, fs, BANDS, 60.0)
}
