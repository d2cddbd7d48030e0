//! Tables, the culling curve and the time-vs-error plot of the results.

use super::*;

/// Culling curve on the typical impact scenes: mode-samples and LSD per quality.
pub(super) fn culling_rows(rows: &[Row]) -> String {
    let mut s = String::new();
    for scene in [
        "single impact (wood)",
        "single impact (metal)",
        "bouncing ball (wood)",
        "bouncing ball (metal)",
        "repeated strikes (4/s, metal)",
        "dense impacts (100/s, glass)",
    ] {
        let unculled = rows
            .iter()
            .find(|r| r.scene == scene && r.lever == "culling=off")
            .map_or(0, |r| r.mode_samples);
        for r in rows.iter().filter(|r| {
            r.scene == scene
                && (r.lever.starts_with("quality=") || r.lever == "culling=off" || r.lever == "merging only")
        }) {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.1}× | {:.2} | {:.1} |",
                scene,
                r.lever,
                r.mode_samples,
                unculled as f64 / r.mode_samples.max(1) as f64,
                r.lsd_db,
                r.frame_err_db
            );
        }
    }
    s
}

pub(super) fn fmt(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "–".into()
    } else if v.is_infinite() {
        "∞".into()
    } else {
        format!("{v:.digits$}")
    }
}

pub(super) fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| scene | lever | RT factor | % of one core | ns/sample | ns/mode-sample | mode-samples | SNR dB | ERB-LSD dB |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            r.scene,
            r.lever,
            fmt(r.rt_factor, 1),
            fmt(r.core_percent(), 3),
            fmt(r.ns_per_sample, 1),
            fmt(r.ns_per_mode_sample, 3),
            r.mode_samples,
            fmt(r.snr_db, 1),
            fmt(r.lsd_db, 3)
        );
    }
    s
}

pub(super) fn machine() -> String {
    let lscpu = std::process::Command::new("lscpu")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    let pick = |key: &str| {
        lscpu
            .lines()
            .find(|l| l.starts_with(key))
            .map(|l| l[key.len()..].trim().to_string())
            .unwrap_or_else(|| "?".into())
    };
    let date = std::process::Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let (kernel, best) = (Kernel::detect(), Kernel::best());
    format!(
        "- CPU: {} ({} CPUs)\n- Date: {}\n- Load average at start (1/5/15 min): {}\n- Kernel auto-detected: {:?}{}\n",
        pick("Model name:"),
        pick("CPU(s):"),
        date,
        load.split_whitespace().take(3).collect::<Vec<_>>().join(" "),
        kernel,
        if kernel == best {
            String::new()
        } else {
            format!(" (limited by --kernel; this CPU's best is {best:?})")
        }
    )
}

pub(super) fn plot(rows: &[Row], path: &Path) -> anyhow::Result<()> {
    use plotters::prelude::*;
    crate::plot_font::register()
        .map_err(|e| anyhow::anyhow!("{}: cannot draw plot ({e})", path.display()))?;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let series: Vec<(&str, Vec<(f64, f64)>)> = [
        "single impact (wood)",
        "single impact (metal)",
        "bouncing ball (wood)",
        "repeated strikes (4/s, metal)",
        "dense impacts (100/s, glass)",
    ]
    .iter()
    .map(|&sc| {
        (
            sc,
            rows.iter()
                .filter(|r| r.scene == sc && r.lever.starts_with("quality="))
                .map(|r| (r.ns_per_sample, r.lsd_db.max(1e-3)))
                .collect(),
        )
    })
    .collect();
    let xmax = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.0))
        .fold(1.0, f64::max)
        * 1.1;
    let ymax = series
        .iter()
        .flat_map(|s| s.1.iter().map(|p| p.1))
        .fold(0.1, f64::max)
        * 1.5;
    let mut chart = ChartBuilder::on(&root)
        .caption("Run time vs error (quality sweep)", ("sans-serif", 20))
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..xmax, (1e-3..ymax).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("wall ns per output sample (48 kHz, block 64)")
        .y_desc("ERB-band LSD vs unculled, dB")
        .draw()?;
    let colors = [RED, BLUE, MAGENTA, CYAN, GREEN];
    for ((name, pts), c) in series.into_iter().zip(colors) {
        chart
            .draw_series(LineSeries::new(pts.clone(), c))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c));
        chart.draw_series(PointSeries::of_element(pts, 4, c, &|p, s, st| {
            Circle::new(p, s, st.filled())
        }))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}
