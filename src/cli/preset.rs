//! `tactus preset show`: a preset file validated and its statistics listed; `tactus preset
//! worst-case`: the most expensive presets validation accepts, written for real-time tests in
//! other processes (tests/host), so they test the very presets the unit tests do.
//! `tactus preset list`: the built-in materials with where each came from.

use std::path::{Path, PathBuf};
use tactus::engine::object::spacing_octaves;
use tactus::preset::{ModeModel, Preset};

/// `tactus preset` and its subcommands.
#[derive(clap::Subcommand)]
pub enum Command {
    /// Validate a preset file and print its statistics.
    Show {
        /// Preset JSON file.
        preset: PathBuf,
    },
    /// List every built-in material: its name (what a scene's `material` takes), class,
    /// origin (recordings, measured mode tables, derived) and sources.
    List {
        /// Print JSON (an array of {index, name, class, origin, sources}) instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Write the most expensive preset validation accepts (every draw fills the engine's mode
    /// limit), for real-time and timing tests in hosts.
    WorstCase {
        /// Which worst case: every mode plain, building up, or ringing after its knock.
        #[arg(long, value_enum, default_value = "plain")]
        kind: WorstCase,
        /// Output preset JSON file.
        #[arg(short, long)]
        output: PathBuf,
    },
}

/// The worst cases of `tactus preset worst-case --kind`.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum WorstCase {
    /// `preset::worst_case_preset`.
    Plain,
    /// `preset::worst_case_build_up_preset`.
    BuildUp,
    /// `preset::worst_case_ring_preset`.
    Ring,
}

/// `tactus preset …`.
pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Show { preset } => run_show(&preset),
        Command::WorstCase { kind, output } => {
            let p = match kind {
                WorstCase::Plain => tactus::preset::worst_case_preset(),
                WorstCase::BuildUp => tactus::preset::worst_case_build_up_preset(),
                WorstCase::Ring => tactus::preset::worst_case_ring_preset(),
            };
            std::fs::write(&output, p.to_json())
                .map_err(|e| anyhow::anyhow!("{}: cannot write the preset: {e}", output.display()))
        }
        Command::List { json } => run_list(json),
    }
}

/// `tactus preset list`.
pub fn run_list(json: bool) -> anyhow::Result<()> {
    let list = tactus::engine::catalog::builtin_list();
    let text = if json {
        serde_json::to_string_pretty(&list).map_err(|e| anyhow::anyhow!("{e}"))? + "\n"
    } else {
        tactus::engine::catalog::table(&list)
    };
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match std::io::Write::write_all(&mut out, text.as_bytes()).and_then(|()| std::io::Write::flush(&mut out))
    {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r.map_err(|e| anyhow::anyhow!("cannot write to stdout: {e}")),
    }
}

/// `tactus preset show`. Output written to a locked stdout; a closed pipe (`| head`) ends the
/// listing successfully instead of panicking.
pub fn run_show(path: &Path) -> anyhow::Result<()> {
    let p = Preset::load(path)?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match write_show(&mut out, &p).and_then(|()| std::io::Write::flush(&mut out)) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r.map_err(|e| anyhow::anyhow!("cannot write to stdout: {e}")),
    }
}

/// The `preset show` listing of `p` into `out`.
pub fn write_show(out: &mut dyn std::io::Write, p: &Preset) -> std::io::Result<()> {
    writeln!(
        out,
        "{} ({}, {:?}), format {}",
        p.name, p.material_class, p.origin, p.format_version
    )?;
    writeln!(out, "method: {}", p.provenance.method)?;
    writeln!(
        out,
        "sources: {} ({} {})",
        p.provenance.sources.len(),
        p.provenance.date,
        p.provenance.tool_version
    )?;
    match &p.modes {
        ModeModel::Fixed { modes } => {
            writeln!(out, "fixed modes: {}", modes.len())?;
            for m in modes {
                writeln!(
                    out,
                    "  {:9.1} Hz {:7.1} dB {:8.1} dB/s",
                    m.freq_hz, m.level_db, m.decay_db_per_s
                )?;
            }
        }
        ModeModel::Distribution(d) => {
            let m = d.count;
            let g = &d.gaussian;
            writeln!(
                out,
                "mode distribution: {m} modes, mean spacing {:.3} octaves (measured {:.3} on the means)",
                d.mean_spacing_octaves,
                spacing_octaves((0..m).map(|i| g.mean[2 * m + i].exp2()))
            )?;
            writeln!(
                out,
                "  {:>4} {:>9} {:>6} {:>8} {:>6} {:>9} {:>6}",
                "rank", "Hz", "sd oct", "level dB", "sd", "dB/s", "sd ln"
            )?;
            for i in 0..m {
                writeln!(
                    out,
                    "  {:>4} {:>9.1} {:>6.3} {:>8.1} {:>6.1} {:>9.1} {:>6.2}",
                    i,
                    g.mean[2 * m + i].exp2(),
                    g.covariance[2 * m + i][2 * m + i].sqrt(),
                    g.mean[i],
                    g.covariance[i][i].sqrt(),
                    match (d.decay, &p.damping) {
                        (tactus::preset::DecayCoordinates::DampingResidual, Some(law)) => {
                            law.residual_base_db_per_s(g.mean[2 * m + i].exp2()) * g.mean[m + i].exp()
                        }
                        _ => g.mean[m + i].exp(),
                    },
                    g.covariance[m + i][m + i].sqrt()
                )?;
            }
        }
    }
    if let Some(t) = &p.transient {
        let n = t.bands;
        let lv = &t.gaussian.mean[..n];
        writeln!(
            out,
            "transient: {n} bands {:.0}..{:.0} Hz, level {:.1}..{:.1} dB, decay {:.0}..{:.0} dB/s",
            t.low_hz,
            t.high_hz,
            lv.iter().cloned().fold(f64::INFINITY, f64::min),
            lv.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            t.gaussian.mean[n..]
                .iter()
                .map(|v| v.exp())
                .fold(f64::INFINITY, f64::min),
            t.gaussian.mean[n..]
                .iter()
                .map(|v| v.exp())
                .fold(f64::NEG_INFINITY, f64::max)
        )?;
    }
    if let Some(d) = &p.damping {
        writeln!(
                out,
            "damping: alpha1 {:.3} 1/s, alpha2 {:.3e} s, alpha3 {:.3}, sigma {:.3}, eta {:.4}; 1 kHz decay {:.1} dB/s",
            d.alpha1,
            d.alpha2,
            d.alpha3,
            d.sigma,
            d.eta,
            d.decay_db_per_s(1000.0)
        )?;
    }
    for f in &p.families {
        let modes = match &f.modes {
            ModeModel::Distribution(d) => format!(
                "{} modes {:.0}..{:.0} Hz",
                d.count,
                d.gaussian.mean[2 * d.count].exp2(),
                d.gaussian.mean[3 * d.count - 1].exp2()
            ),
            ModeModel::Fixed { modes } => format!("{} fixed modes", modes.len()),
        };
        let law = f
            .damping
            .map(|d| format!(", 1 kHz decay {:.1} dB/s", d.decay_db_per_s(1000.0)))
            .unwrap_or_default();
        writeln!(out, "family {}: weight {}, {modes}{law}", f.name, f.weight)?;
    }
    writeln!(out, "contact stiffness: {:.3e} N/m", p.contact_stiffness_n_per_m)?;
    Ok(())
}
