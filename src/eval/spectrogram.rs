//! `tactus eval --spectrograms DIR`: a PNG per preset with the spectrogram of one recording
//! beside those of draws 1–3, by the same analysis and on the same colour scale, so the eye can
//! compare attack, ringing and the decay of high against low partials.
//!
//! Layout: four panels left to right (recording, draw 1, draw 2, draw 3), each time 0 to
//! [`SPAN_S`] from the onset (left to right) × frequency [`BAND_HZ`] on a logarithmic axis (low
//! at the bottom). Colour: level relative to the panel's own maximum, black at
//! −[`RANGE_DB`] dB or below to pale yellow at 0 dB (each sound's own peak: recordings and renders
//! have unrelated gains).

use crate::eval::draws;
use crate::fit::{audio, extract};
use crate::preset::Preset;
use realfft::RealFftPlanner;
use std::path::Path;

/// Time shown per panel, s.
pub const SPAN_S: f64 = 1.5;
/// Frequency band shown, Hz.
pub const BAND_HZ: (f64, f64) = (50.0, 9_000.0);
/// Level range of the colour scale, dB below the panel's maximum.
pub const RANGE_DB: f64 = 80.0;
/// Analysis window (Hann), s: 1024 samples at 44.1 kHz, the same duration at every rate.
pub const WINDOW_S: f64 = 0.023;
/// Panel size in pixels.
pub const PANEL_PX: (usize, usize) = (320, 240);
/// White gap between panels, pixels.
pub const GAP_PX: usize = 6;

/// File-name form of a preset name: lower case, runs of other characters as `-`.
pub fn slug(name: &str) -> String {
    let s: String = name
        .to_lowercase()
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect();
    s.split('-')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// Level in dB of `x` from its onset, `[column][row]` over the panel grid.
pub fn spectrogram_db(x: &[f64], fs: f64) -> Vec<Vec<f64>> {
    let (onset, dc) = extract::onset_and_dc(x);
    let y: Vec<f64> = x[onset..].iter().map(|v| v - dc).collect();
    let n = ((WINDOW_S * fs).round() as usize).max(16);
    let nfft = (4 * n).next_power_of_two();
    let win: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * (i as f64 + 0.5) / n as f64).cos())
        .collect();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let mut spec = fft.make_output_vec();
    let (w, h) = PANEL_PX;
    let (lo, hi) = (BAND_HZ.0.log2(), BAND_HZ.1.min(0.5 * fs).log2());
    (0..w)
        .map(|c| {
            let centre = ((c as f64 + 0.5) / w as f64 * SPAN_S * fs) as isize;
            let mut buf = vec![0.0; nfft];
            for i in 0..n {
                let k = centre - (n / 2) as isize + i as isize;
                if k >= 0 && (k as usize) < y.len() {
                    buf[i] = y[k as usize] * win[i];
                }
            }
            let _ = fft.process(&mut buf, &mut spec);
            (0..h)
                .map(|r| {
                    let f = (lo + (r as f64 + 0.5) / h as f64 * (hi - lo)).exp2();
                    let bin = ((f * nfft as f64 / fs).round() as usize).min(spec.len() - 1);
                    20.0 * spec[bin].norm().max(1e-300).log10()
                })
                .collect()
        })
        .collect()
}

/// Black → purple → orange → pale yellow for `t` in 0..=1.
fn colour(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [60.0, 10.0, 100.0],
        [180.0, 40.0, 90.0],
        [250.0, 140.0, 30.0],
        [252.0, 250.0, 190.0],
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    std::array::from_fn(|k| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])).round() as u8)
}

/// Writes the panels (each `[column][row]` in dB) side by side as an RGB PNG.
pub fn write_png(path: &Path, panels: &[Vec<Vec<f64>>]) -> anyhow::Result<()> {
    let (w, h) = PANEL_PX;
    let width = panels.len() * w + (panels.len().saturating_sub(1)) * GAP_PX;
    let mut rgb = vec![255u8; width * h * 3];
    for (p, panel) in panels.iter().enumerate() {
        let top = panel.iter().flatten().cloned().fold(f64::NEG_INFINITY, f64::max);
        let x0 = p * (w + GAP_PX);
        for (c, col) in panel.iter().enumerate() {
            for (r, &db) in col.iter().enumerate() {
                let px = colour(1.0 + (db - top) / RANGE_DB);
                let (x, y) = (x0 + c, h - 1 - r);
                rgb[(y * width + x) * 3..][..3].copy_from_slice(&px);
            }
        }
    }
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot write {}: {e}", path.display());
    let file = std::fs::File::create(path).map_err(|e| err(&e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width as u32, h as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc.write_header().map_err(|e| err(&e))?;
    wr.write_image_data(&rgb).map_err(|e| err(&e))?;
    wr.finish().map_err(|e| err(&e))?;
    Ok(())
}

/// The recording at `recording` beside draws 1–3 of `preset` (see the module docs).
pub fn write_comparison(path: &Path, recording: &Path, preset: &Preset) -> anyhow::Result<()> {
    let rec = audio::read_wav(recording)?;
    let mut panels = vec![spectrogram_db(&rec.samples, rec.sample_rate)];
    for seed in 1..=3 {
        panels.push(spectrogram_db(
            &draws::render_draw(preset, seed),
            draws::RENDER_FS,
        ));
    }
    write_png(path, &panels)
}
