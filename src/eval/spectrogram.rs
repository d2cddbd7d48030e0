//! `tactus eval --spectrograms DIR`: a PNG per preset with the spectrogram of one recording
//! beside those of draws 1–3, by the same analysis and on the same colour scale, so the eye can
//! compare attack, ringing and the decay of high against low partials.
//!
//! Layout: four panels left to right (recording, draw 1, draw 2, draw 3), each titled with what
//! it shows (the recording's file name, the draw's preset and seed), time 0 to [`SPAN_S`] from
//! the onset in s on the horizontal axis, frequency [`BAND_HZ`] in Hz on a logarithmic vertical
//! axis; a colour bar on the right. Colour: level relative to the panel's own maximum, black at
//! −[`RANGE_DB`] dB or below to pale yellow at 0 dB (each sound's own peak: recordings and
//! renders have unrelated gains). Drawn with plotters into an RGB buffer, written by `png`.
//! [`write_grid`] lays panels out in rows ([`Layout`]) with their own span and band: the
//! measured materials' and surfaces' contact sheets (`tactus measured spectrograms`).

use crate::analysis::{audio, render, signal};
use crate::preset::Preset;
use plotters::prelude::*;
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
/// Size of one panel with its title, axes and labels, pixels.
pub const PANEL_PX: (u32, u32) = (400, 330);
/// Width of the colour bar with its axis, pixels.
pub const BAR_PX: u32 = 110;
/// Height of the figure's title line, pixels.
pub const TITLE_PX: u32 = 34;
/// Frequencies labelled on the vertical axis, Hz.
const FREQ_TICKS_HZ: [f64; 9] = [
    50.0, 100.0, 200.0, 500.0, 1_000.0, 2_000.0, 5_000.0, 9_000.0, 16_000.0,
];

/// Size of the whole figure for `panels` panels in one row, pixels.
pub fn figure_px(panels: usize) -> (u32, u32) {
    Layout::row(panels).figure_px(panels)
}

/// How a figure lays out its panels: a grid of `columns`, each panel `panel_px` showing
/// `span_s` from the onset over `band_hz`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// Panels per row.
    pub columns: usize,
    /// Time shown per panel, s.
    pub span_s: f64,
    /// Frequency band shown, Hz.
    pub band_hz: (f64, f64),
    /// Size of one panel with its title, axes and labels, pixels.
    pub panel_px: (u32, u32),
}

impl Layout {
    /// `panels` panels in one row at [`SPAN_S`], [`BAND_HZ`], [`PANEL_PX`].
    pub fn row(panels: usize) -> Self {
        Self {
            columns: panels.max(1),
            span_s: SPAN_S,
            band_hz: BAND_HZ,
            panel_px: PANEL_PX,
        }
    }

    /// Rows of `panels` panels.
    pub fn rows(&self, panels: usize) -> usize {
        panels.div_ceil(self.columns.max(1)).max(1)
    }

    /// Size of the whole figure for `panels` panels, pixels.
    pub fn figure_px(&self, panels: usize) -> (u32, u32) {
        (
            self.columns as u32 * self.panel_px.0 + BAR_PX,
            self.rows(panels) as u32 * self.panel_px.1 + TITLE_PX,
        )
    }
}

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

/// Level in dB of `x` from its onset on a grid of `(columns, rows)`: column `c` is the time
/// `(c + ½)/columns · SPAN_S`, row `r` (from the bottom) the frequency `(r + ½)/rows` of the
/// way up [`BAND_HZ`] on a log axis. Returned `[column][row]`.
pub fn spectrogram_db(x: &[f64], fs: f64, size: (usize, usize)) -> Vec<Vec<f64>> {
    spectrogram_db_over(x, fs, SPAN_S, BAND_HZ, size)
}

/// [`spectrogram_db`] over `span_s` and `band_hz`.
pub fn spectrogram_db_over(
    x: &[f64],
    fs: f64,
    span_s: f64,
    band_hz: (f64, f64),
    (w, h): (usize, usize),
) -> Vec<Vec<f64>> {
    let y = signal::from_onset(x);
    let n = ((WINDOW_S * fs).round() as usize).max(16);
    let nfft = (4 * n).next_power_of_two();
    let win: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * (i as f64 + 0.5) / n as f64).cos())
        .collect();
    let mut planner = RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(nfft);
    let mut spec = fft.make_output_vec();
    let (lo, hi) = (band_hz.0.log2(), band_hz.1.min(0.5 * fs).log2());
    (0..w)
        .map(|c| {
            let centre = ((c as f64 + 0.5) / w as f64 * span_s * fs) as isize;
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
fn colour(t: f64) -> RGBColor {
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
    let c: [u8; 3] =
        std::array::from_fn(|k| (STOPS[i][k] + f * (STOPS[i + 1][k] - STOPS[i][k])).round() as u8);
    RGBColor(c[0], c[1], c[2])
}

/// One panel: a sound and the title it is shown under.
pub struct Panel<'a> {
    /// Title above the panel (a file name, or a preset's draw).
    pub title: String,
    /// The sound, mono.
    pub samples: &'a [f64],
    /// Its sample rate, Hz.
    pub fs: f64,
}

/// Frequency tick label: whole hertz below 1 kHz, kHz above (`2k`).
fn hz_label(f: &f64) -> String {
    if *f >= 1_000.0 {
        format!("{}k", f / 1_000.0)
    } else {
        format!("{f}")
    }
}

/// Draws `panels` in `layout`'s grid under `title` with a dB colour bar into `buf` (RGB, the
/// size of [`Layout::figure_px`]).
fn draw(
    buf: &mut [u8],
    title: &str,
    panels: &[Panel],
    layout: &Layout,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    crate::plot_font::register()?;
    let font = crate::plot_font::FAMILY;
    let (width, height) = layout.figure_px(panels.len());
    let root = BitMapBackend::with_buffer(buf, (width, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = root.titled(title, (font, 18))?;
    let (left, bar) = body.split_horizontally(layout.columns as u32 * layout.panel_px.0);
    let cells = left.split_evenly((layout.rows(panels.len()), layout.columns));
    for (area, p) in cells.iter().zip(panels) {
        let top_hz = layout.band_hz.1.min(0.5 * p.fs);
        let ticks: Vec<f64> = FREQ_TICKS_HZ
            .iter()
            .copied()
            .filter(|f| (layout.band_hz.0..=top_hz).contains(f))
            .collect();
        let mut chart = ChartBuilder::on(area)
            .caption(&p.title, (font, 14))
            .margin(8)
            .margin_right(14)
            .x_label_area_size(38)
            .y_label_area_size(52)
            .build_cartesian_2d(
                0.0..layout.span_s,
                (layout.band_hz.0..top_hz).log_scale().with_key_points(ticks),
            )?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(4)
            .x_label_formatter(&|t| format!("{t:.1}"))
            .y_label_formatter(&hz_label)
            .x_desc("time from onset, s")
            .y_desc("frequency, Hz")
            .label_style((font, 12))
            .axis_desc_style((font, 13))
            .draw()?;
        let plot = chart.plotting_area().strip_coord_spec();
        let (w, h) = plot.dim_in_pixel();
        let db = spectrogram_db_over(
            p.samples,
            p.fs,
            layout.span_s,
            layout.band_hz,
            (w as usize, h as usize),
        );
        let top = db.iter().flatten().cloned().fold(f64::NEG_INFINITY, f64::max);
        for (c, col) in db.iter().enumerate() {
            for (r, &v) in col.iter().enumerate() {
                plot.draw_pixel(
                    (c as i32, h as i32 - 1 - r as i32),
                    &colour(1.0 + (v - top) / RANGE_DB),
                )?;
            }
        }
    }
    // The colour bar: one band per 0.5 dB over the scale, on the panels' vertical extent.
    let mut scale = ChartBuilder::on(&bar)
        .caption(" ", (font, 14))
        .margin(8)
        .margin_left(0)
        .margin_right(50)
        .x_label_area_size(38)
        .y_label_area_size(44)
        .build_cartesian_2d(0.0..1.0, -RANGE_DB..0.0)?;
    scale
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .y_labels(9)
        .y_label_formatter(&|v| format!("{v:.0}"))
        .y_desc("level, dB re panel maximum")
        .label_style((font, 12))
        .axis_desc_style((font, 13))
        .draw()?;
    let steps = (2.0 * RANGE_DB) as usize;
    scale.draw_series((0..steps).map(|k| {
        let lo = -RANGE_DB + k as f64 * 0.5;
        Rectangle::new([(0.0, lo), (1.0, lo + 0.5)], colour(1.0 + lo / RANGE_DB).filled())
    }))?;
    root.present()?;
    Ok(())
}

/// Writes `panels` (see the module docs) in one row under `title` as an RGB PNG of
/// [`figure_px`].
pub fn write_png(path: &Path, title: &str, panels: &[Panel]) -> anyhow::Result<()> {
    write_grid(path, title, panels, &Layout::row(panels.len()))
}

/// Writes `panels` in `layout`'s grid (left to right, then down) under `title` as an RGB PNG
/// of [`Layout::figure_px`].
pub fn write_grid(path: &Path, title: &str, panels: &[Panel], layout: &Layout) -> anyhow::Result<()> {
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot write {}: {e}", path.display());
    let (width, height) = layout.figure_px(panels.len());
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    draw(&mut rgb, title, panels, layout).map_err(|e| err(&e))?;
    let file = std::fs::File::create(path).map_err(|e| err(&e))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc.write_header().map_err(|e| err(&e))?;
    wr.write_image_data(&rgb).map_err(|e| err(&e))?;
    wr.finish().map_err(|e| err(&e))?;
    Ok(())
}

/// The recording at `recording` beside draws 1–3 of `preset` (see the module docs).
pub fn write_comparison(path: &Path, recording: &Path, preset: &Preset) -> anyhow::Result<()> {
    let rec = audio::read_recording(recording)?;
    let seconds = render::seconds_like([rec.samples.len() as f64 / rec.sample_rate]);
    let renders: Vec<Vec<f64>> = (1..=3)
        .map(|seed| render::render_draw(preset, seed, seconds))
        .collect();
    let mut panels = vec![Panel {
        title: crate::analysis::labels::file_name(recording),
        samples: &rec.samples,
        fs: rec.sample_rate,
    }];
    for (seed, x) in (1..).zip(&renders) {
        panels.push(Panel {
            title: format!("{}, draw {seed}", preset.name),
            samples: x,
            fs: render::RENDER_FS,
        });
    }
    let title = format!(
        "{}: a recording and three draws (new objects, default hit), level re each panel's maximum",
        preset.name
    );
    write_png(path, &title, &panels)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A decaying 440 Hz partial from 0.05 s (so the onset is found), at 44.1 kHz.
    fn tone() -> Vec<f64> {
        let fs = 44_100.0;
        (0..(1.6 * fs) as usize)
            .map(|i| {
                let t = i as f64 / fs - 0.05;
                if t < 0.0 {
                    0.0
                } else {
                    (-3.0 * t).exp() * (std::f64::consts::TAU * 440.0 * t).sin()
                }
            })
            .collect()
    }

    /// The PNG is the figure's size, the axes' tick labels and titles are drawn (dark pixels in
    /// the label strips, outside the plotting areas) and the colour bar holds its gradient.
    #[test]
    fn png_has_axes_labels_and_colour_bar() {
        let x = tone();
        let panels: Vec<Panel> = (0..2)
            .map(|i| Panel {
                title: format!("tone_{i}.wav"),
                samples: &x,
                fs: 44_100.0,
            })
            .collect();
        let path = std::env::temp_dir().join(format!("tactus_spectrogram_{}.png", std::process::id()));
        write_png(&path, "Test", &panels).expect("written");
        let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = dec.read_info().expect("a PNG");
        let mut img = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut img).expect("decodes");
        assert_eq!((info.width, info.height), figure_px(2));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        let w = info.width as usize;
        let px = |x: usize, y: usize| -> [u8; 3] { std::array::from_fn(|k| img[(y * w + x) * 3 + k]) };
        let dark = |x0: usize, x1: usize, y0: usize, y1: usize| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| px(x, y).iter().all(|&v| v < 128))
                .count()
        };
        let (pw, ph) = (PANEL_PX.0 as usize, PANEL_PX.1 as usize);
        let top = TITLE_PX as usize;
        // Frequency tick labels and axis title: the left 52 px of the first panel.
        assert!(
            dark(8, 8 + 52, top + 30, top + ph - 46) > 100,
            "no frequency axis labels"
        );
        // Time tick labels and axis title: the bottom 38 px of the first panel.
        assert!(
            dark(70, pw - 20, top + ph - 46, top + ph - 8) > 100,
            "no time axis labels"
        );
        // The figure's title.
        assert!(dark(0, 2 * pw, 0, top) > 50, "no title");
        // The colour bar (right of its 44 px label strip): pale yellow at its top, black at its
        // bottom, in one column.
        let bx = 2 * pw + 52;
        let col: Vec<[u8; 3]> = (top..top + ph).map(|y| px(bx, y)).collect();
        assert!(
            col.iter()
                .any(|c| c[0] > 240 && c[1] > 230 && c[2] > 150 && c[2] < 220),
            "no 0 dB colour"
        );
        assert!(col.contains(&[0, 0, 0]), "no -80 dB colour");
        // The spectrogram itself: the 440 Hz partial is bright in the first panel's plotting area.
        let bright = (top..top + ph)
            .flat_map(|y| (60..pw - 14).map(move |x| (x, y)))
            .filter(|&(x, y)| px(x, y)[0] > 240 && px(x, y)[1] > 200)
            .count();
        assert!(bright > 50, "no bright partial ({bright} px)");
        // Kept for inspection when an assertion above fails.
        let _ = std::fs::remove_file(&path);
    }
}
