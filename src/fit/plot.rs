//! `tactus fit --plot DIR`: SVG plots of a fit (plotters, SVG backend).
//!
//! - `modes_<file>.svg`, one per recording: the extracted modes, frequency (log axis) × onset
//!   level (dB re the file's strongest mode); marker colour = decay (blue slow → red fast, log
//!   scale over the file's range), marker size grows with level.
//! - `damping.svg`: damping `c = 2·decay/(20·log10 e)` (1/s) of every extracted mode (after
//!   merging near-coincident copies, as the fit does) vs
//!   frequency (log–log), with the Rayleigh curves `c = α1 + α2·ω²` of the EMG maximum-likelihood
//!   fit (what the preset stores), ordinary least squares and the strict lower bound.
//! - `distributions.svg`: measured modes (each recording's `count` strongest by energy after
//!   merging near-coincident copies, as pooled by the fit) against [`SAMPLED_MODES`] modes drawn from the fitted preset: decay vs frequency,
//!   level vs frequency, and histograms of log2 frequency, level and ln decay.

use crate::analysis::signal::Mode;
use crate::engine::dsp::DB_PER_NEPER;
use crate::engine::object::{EngineRng, ObjectSampler, SampledObject};
use crate::fit::pool::damping::{fit_emg, fit_least_squares, fit_lower_bound, DampingFit};
use crate::fit::recording::modes::{consolidate, CONSOLIDATE_REL};
use crate::fit::recording::FileResult;
use crate::preset::{ModeModel, Preset};
use plotters::coord::Shift;
use plotters::prelude::*;
use rand::SeedableRng;
use std::path::{Path, PathBuf};

/// Modes sampled from the fitted preset for the distribution plot.
pub const SAMPLED_MODES: usize = 500;

type DrawResult<T> = Result<T, Box<dyn std::error::Error>>;

fn err(e: Box<dyn std::error::Error>, path: &Path) -> anyhow::Error {
    anyhow::anyhow!("{}: cannot draw plot ({e})", path.display())
}

/// Writes every plot of a fit into `dir` (created if needed); returns the files written.
pub fn write_plots(dir: &Path, results: &[FileResult], preset: &Preset) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)
        .map_err(|e| anyhow::anyhow!("{}: cannot create folder ({e})", dir.display()))?;
    crate::plot_font::register()
        .map_err(|e| anyhow::anyhow!("{}: cannot draw plots ({e})", dir.display()))?;
    let mut out = Vec::new();
    for r in results {
        let stem = Path::new(&r.name)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "recording".into());
        let p = dir.join(format!("modes_{stem}.svg"));
        plot_modes(&p, &stem, &r.modes).map_err(|e| err(e, &p))?;
        out.push(p);
    }
    let p = dir.join("damping.svg");
    plot_damping(&p, results).map_err(|e| err(e, &p))?;
    out.push(p);
    if let ModeModel::Distribution(d) = &preset.modes {
        let p = dir.join("distributions.svg");
        plot_distributions(&p, results, preset, d.count).map_err(|e| err(e, &p))?;
        out.push(p);
    }
    Ok(out)
}

/// Blue (t = 0) → red (t = 1).
fn ramp(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    RGBColor(
        (40.0 + 215.0 * t) as u8,
        (60.0 + 80.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
        (255.0 * (1.0 - t)) as u8,
    )
}

fn log_range(v: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite() && *x > 0.0) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return (1.0, 10.0);
    }
    if hi <= lo * 1.01 {
        hi = lo * 2.0;
    }
    (lo / pad, hi * pad)
}

fn lin_range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for x in v.filter(|x| x.is_finite()) {
        lo = lo.min(x);
        hi = hi.max(x);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = 0.05 * (hi - lo).max(1e-9);
    (lo - pad, hi + pad)
}

fn plot_modes(path: &Path, title: &str, modes: &[Mode]) -> DrawResult<()> {
    let root = SVGBackend::new(path, (900, 520)).into_drawing_area();
    root.fill(&WHITE)?;
    let top = modes.iter().map(|m| m.level_db).fold(f64::NEG_INFINITY, f64::max);
    let (f0, f1) = log_range(modes.iter().map(|m| m.freq_hz), 1.2);
    let (l0, _) = lin_range(modes.iter().map(|m| m.level_db - top));
    let (d0, d1) = log_range(modes.iter().map(|m| m.decay_db_per_s), 1.0);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "{title}: {} modes (colour: decay {d0:.1} dB/s blue .. {d1:.0} dB/s red)",
                modes.len()
            ),
            ("sans-serif", 16),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((f0..f1).log_scale(), l0.min(-1.0)..3.0)?;
    chart
        .configure_mesh()
        .light_line_style(BLACK.mix(0.04))
        .x_desc("frequency, Hz")
        .y_desc("onset level, dB re strongest mode")
        .draw()?;
    let span = (d1 / d0).ln().max(1e-9);
    chart.draw_series(modes.iter().map(|m| {
        let t = (m.decay_db_per_s.max(d0) / d0).ln() / span;
        let size = (3.0 + 9.0 * (1.0 + (m.level_db - top) / 60.0).clamp(0.0, 1.0)) as i32;
        Circle::new((m.freq_hz, m.level_db - top), size, ramp(t).filled())
    }))?;
    // Stems make the line spectrum readable.
    chart.draw_series(modes.iter().map(|m| {
        PathElement::new(
            vec![(m.freq_hz, l0.min(-1.0)), (m.freq_hz, m.level_db - top)],
            BLACK.mix(0.3),
        )
    }))?;
    root.present()?;
    Ok(())
}

fn plot_damping(path: &Path, results: &[FileResult]) -> DrawResult<()> {
    let (omega, c): (Vec<f64>, Vec<f64>) = results
        .iter()
        .flat_map(|r| consolidate(&r.modes, CONSOLIDATE_REL))
        .map(|m| {
            (
                std::f64::consts::TAU * m.freq_hz,
                2.0 * m.decay_db_per_s / DB_PER_NEPER,
            )
        })
        .unzip();
    let root = SVGBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let (f0, f1) = log_range(omega.iter().map(|w| w / std::f64::consts::TAU), 1.2);
    let (c0, c1) = log_range(c.iter().cloned(), 1.5);
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("Damping of {} modes from {} recordings", c.len(), results.len()),
            ("sans-serif", 18),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((f0..f1).log_scale(), (c0..c1).log_scale())?;
    chart
        .configure_mesh()
        .light_line_style(BLACK.mix(0.04))
        .x_desc("frequency, Hz")
        .y_desc("damping c = 2 x decay rate, 1/s")
        .draw()?;
    chart
        .draw_series(
            omega
                .iter()
                .zip(&c)
                .map(|(w, c)| Circle::new((w / std::f64::consts::TAU, *c), 3, BLACK.mix(0.5).filled())),
        )?
        .label("measured modes")
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLACK.filled()));
    let mut fits: Vec<(String, DampingFit, RGBColor)> = Vec::new();
    if let Some(e) = fit_emg(&omega, &c, false) {
        fits.push((
            format!("EMG MLE: a1 {:.2} 1/s, a2 {:.2e} s", e.alpha1, e.alpha2),
            e,
            RED,
        ));
    }
    if omega.len() >= 2 {
        let ls = fit_least_squares(&omega, &c);
        fits.push((
            format!("least squares: a1 {:.2}, a2 {:.2e}", ls.alpha1, ls.alpha2),
            ls,
            BLUE,
        ));
        let lb = fit_lower_bound(&omega, &c);
        fits.push((
            format!("lower bound: a1 {:.2}, a2 {:.2e}", lb.alpha1, lb.alpha2),
            lb,
            GREEN,
        ));
    }
    for (name, fit, col) in fits {
        let pts: Vec<(f64, f64)> = (0..=200)
            .map(|i| {
                let f = f0 * (f1 / f0).powf(f64::from(i) / 200.0);
                (f, fit.c(std::f64::consts::TAU * f).clamp(c0, c1))
            })
            .collect();
        chart
            .draw_series(LineSeries::new(pts, col.stroke_width(2)))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], col.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// (log2 Hz, level dB re the object's strongest, ln dB/s) of measured and sampled modes.
type Triple = (f64, f64, f64);

fn measured_triples(results: &[FileResult], count: usize) -> Vec<Triple> {
    let mut out = Vec::new();
    for r in results {
        let mut m = consolidate(&r.modes, CONSOLIDATE_REL);
        m.truncate(count);
        let top = m.iter().map(|x| x.level_db).fold(f64::NEG_INFINITY, f64::max);
        if !top.is_finite() {
            continue;
        }
        out.extend(m.iter().map(|x| {
            (
                x.freq_hz.log2(),
                x.level_db - top,
                x.decay_db_per_s.max(0.05).ln(),
            )
        }));
    }
    out
}

fn sampled_triples(preset: &Preset) -> Vec<Triple> {
    let mut sampler = ObjectSampler::new(preset);
    let mut rng = EngineRng::seed_from_u64(1);
    let mut obj = SampledObject::with_capacity();
    let mut out = Vec::with_capacity(SAMPLED_MODES);
    while out.len() < SAMPLED_MODES {
        sampler.sample(&mut rng, &mut obj);
        if obj.modes.is_empty() {
            break;
        }
        let top = obj
            .modes
            .iter()
            .map(|m| m.level_db)
            .fold(f64::NEG_INFINITY, f64::max);
        for m in &obj.modes {
            if out.len() < SAMPLED_MODES {
                out.push((
                    m.freq_hz.log2(),
                    m.level_db - top,
                    m.decay_db_per_s.max(0.05).ln(),
                ));
            }
        }
    }
    out
}

fn scatter_panel(
    area: &DrawingArea<SVGBackend, Shift>,
    title: &str,
    y_desc: &str,
    meas: &[(f64, f64)],
    samp: &[(f64, f64)],
) -> DrawResult<()> {
    let (x0, x1) = lin_range(meas.iter().chain(samp).map(|p| p.0));
    let (y0, y1) = lin_range(meas.iter().chain(samp).map(|p| p.1));
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 15))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart
        .configure_mesh()
        .light_line_style(BLACK.mix(0.04))
        .x_desc("log2 frequency (Hz)")
        .y_desc(y_desc)
        .draw()?;
    chart
        .draw_series(samp.iter().map(|p| Circle::new(*p, 2, RED.mix(0.35).filled())))?
        .label(format!("sampled ({})", samp.len()))
        .legend(|(x, y)| Circle::new((x + 10, y), 3, RED.filled()));
    chart
        .draw_series(meas.iter().map(|p| Circle::new(*p, 3, BLUE.filled())))?
        .label(format!("measured ({})", meas.len()))
        .legend(|(x, y)| Circle::new((x + 10, y), 3, BLUE.filled()));
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

fn histogram_panel(
    area: &DrawingArea<SVGBackend, Shift>,
    x_desc: &str,
    meas: &[f64],
    samp: &[f64],
) -> DrawResult<()> {
    let bins = 24usize;
    let (x0, x1) = lin_range(meas.iter().chain(samp).cloned());
    let w = (x1 - x0) / bins as f64;
    let density = |v: &[f64]| -> Vec<f64> {
        let mut h = vec![0.0; bins];
        for x in v {
            let k = (((x - x0) / w) as usize).min(bins - 1);
            h[k] += 1.0;
        }
        let n = v.len().max(1) as f64;
        h.iter().map(|c| c / n).collect()
    };
    let (hm, hs) = (density(meas), density(samp));
    let ymax = hm.iter().chain(&hs).cloned().fold(0.01, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, 0.0..ymax)?;
    chart
        .configure_mesh()
        .light_line_style(BLACK.mix(0.04))
        .x_desc(x_desc)
        .y_desc("fraction of modes")
        .draw()?;
    chart.draw_series(hs.iter().enumerate().map(|(k, v)| {
        let a = x0 + k as f64 * w;
        Rectangle::new([(a, 0.0), (a + w, *v)], RED.mix(0.35).filled())
    }))?;
    chart.draw_series(hm.iter().enumerate().map(|(k, v)| {
        let a = x0 + k as f64 * w;
        Rectangle::new([(a, 0.0), (a + w, *v)], BLUE.stroke_width(2))
    }))?;
    Ok(())
}

fn plot_distributions(path: &Path, results: &[FileResult], preset: &Preset, count: usize) -> DrawResult<()> {
    let meas = measured_triples(results, count);
    let samp = sampled_triples(preset);
    let root = SVGBackend::new(path, (1200, 900)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!(
            "{}: measured modes (blue) vs {} sampled from the fitted preset (red)",
            preset.name,
            samp.len()
        ),
        ("sans-serif", 20),
    )?;
    let (upper, lower) = root.split_vertically(480);
    let top = upper.split_evenly((1, 2));
    let bottom = lower.split_evenly((1, 3));
    let pick = |v: &[Triple], f: fn(&Triple) -> (f64, f64)| -> Vec<(f64, f64)> { v.iter().map(f).collect() };
    scatter_panel(
        &top[0],
        "decay vs frequency",
        "ln decay (dB/s)",
        &pick(&meas, |t| (t.0, t.2)),
        &pick(&samp, |t| (t.0, t.2)),
    )?;
    scatter_panel(
        &top[1],
        "level vs frequency",
        "level, dB re strongest",
        &pick(&meas, |t| (t.0, t.1)),
        &pick(&samp, |t| (t.0, t.1)),
    )?;
    let col = |v: &[Triple], f: fn(&Triple) -> f64| -> Vec<f64> { v.iter().map(f).collect() };
    histogram_panel(
        &bottom[0],
        "log2 frequency (Hz)",
        &col(&meas, |t| t.0),
        &col(&samp, |t| t.0),
    )?;
    histogram_panel(
        &bottom[1],
        "level, dB re strongest",
        &col(&meas, |t| t.1),
        &col(&samp, |t| t.1),
    )?;
    histogram_panel(
        &bottom[2],
        "ln decay (dB/s)",
        &col(&meas, |t| t.2),
        &col(&samp, |t| t.2),
    )?;
    root.present()?;
    Ok(())
}
