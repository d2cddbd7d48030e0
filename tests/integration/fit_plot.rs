//! `tactus fit --plot DIR`: the SVG plots are written and are SVG documents (synthetic
//! recordings, no data files needed).

use crate::common::pool_one_family;
use tactus::analysis::signal::Mode;
use tactus::fit::plot::write_plots;
use tactus::fit::recording::extract::synthesize;
use tactus::fit::recording::fit_signal;

fn recording(fs: f64, f0: f64, decay: f64) -> Vec<f64> {
    let modes: Vec<Mode> = (0..8)
        .map(|i| Mode {
            freq_hz: f0 * (1.0 + 1.7 * i as f64),
            level_db: -6.0 - 3.0 * i as f64,
            decay_db_per_s: decay * (1.0 + 0.5 * i as f64),
            phase: 0.3 * i as f64,
            attack_s: 0.0,
            ring: None,
        })
        .collect();
    let mut x = vec![0.0; (0.02 * fs) as usize];
    x.extend(synthesize(&modes, fs, (0.8 * fs) as usize));
    x
}

#[test]
fn plots_are_written_as_svg() {
    let fs = 44_100.0;
    let results: Vec<_> = [(220.0, 30.0), (310.0, 45.0), (180.0, 25.0)]
        .iter()
        .enumerate()
        .map(|(i, &(f0, d))| {
            fit_signal(
                &recording(fs, f0, d),
                fs,
                &format!("synthetic_{i}.wav"),
                String::new(),
                false,
            )
        })
        .collect();
    let preset = pool_one_family("wood", &results, 6).expect("preset");
    let dir = std::env::temp_dir().join(format!("tactus_fit_plot_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let files = write_plots(&dir, &results, &preset).expect("plots");
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    println!("{names:?}");
    for want in [
        "modes_synthetic_0.svg",
        "modes_synthetic_1.svg",
        "modes_synthetic_2.svg",
        "damping.svg",
        "distributions.svg",
    ] {
        assert!(names.iter().any(|n| n == want), "{want} missing from {names:?}");
    }
    for p in &files {
        let text = std::fs::read_to_string(p).expect("readable");
        assert!(text.len() > 1000, "{}: only {} bytes", p.display(), text.len());
        assert!(
            text.contains("<svg") && text.trim_end().ends_with("</svg>"),
            "{}: not SVG",
            p.display()
        );
        // Every plot draws data points (circles) or bars (rects), not just axes.
        assert!(
            text.contains("<circle") || text.contains("<rect"),
            "{}: no marks",
            p.display()
        );
    }
    let dist = std::fs::read_to_string(dir.join("distributions.svg")).unwrap();
    assert!(dist.matches("<circle").count() >= 500, "sampled modes not drawn");
    let _ = std::fs::remove_dir_all(&dir);
}
