//! `tactus surfaces`: the scraping and rolling surfaces (list; derive the measured ones'
//! statistics from their scans).

use std::path::PathBuf;
use tactus::analysis::surfaces;
use tactus::engine::sustained::SurfaceKind;

/// The subcommands of `tactus surfaces`.
#[derive(clap::Subcommand)]
pub enum Command {
    /// List the surfaces a scene's `surface` (and the plugin's Surface) takes, with the measured
    /// ones' RMS heights.
    List,
    /// Derive the measured surfaces' statistics from their scans (a folder of `<name>.npy` depth
    /// profiles, e.g. ../shared/measured/surfaces) and write them as Rust source
    /// (src/engine/sustained/measured_data.rs); prints what was measured on each file.
    Derive {
        /// Folder of the twelve `.npy` profiles.
        dir: PathBuf,
        /// Output file (Rust source); without it nothing is written.
        #[arg(short, long)]
        out: Option<PathBuf>,
    },
}

/// `tactus surfaces`.
pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::List => {
            for k in SurfaceKind::ALL {
                match k.stats() {
                    Some(s) => println!("{:15} measured, band RMS {:.3} µm", k.name(), s.rms_m * 1e6),
                    None => println!("{:15} synthetic (roughness sets the RMS height)", k.name()),
                }
            }
            Ok(())
        }
        Command::Derive { dir, out } => {
            let derived = surfaces::derive_all(&dir)?;
            println!(
                "{:15} {:>8} {:>11} {:>7} {:>12} {:>10} {:>10}  octave bands 0.5..16 /mm: synthesised − measured, dB",
                "surface", "samples", "spacing µm", "factor", "edge cyc/file", "RMS µm", "band RMS µm"
            );
            for d in &derived {
                let check: Vec<String> = d.check_db.iter().map(|v| format!("{v:+.2}")).collect();
                println!(
                    "{:15} {:>8} {:>11.4} {:>7} {:>12.0} {:>10.4} {:>10.4}  {}",
                    d.stats.name,
                    d.samples,
                    d.spacing_m * 1e6,
                    d.scale,
                    d.edge_cycles,
                    d.rms_raw_m * 1e6,
                    d.stats.rms_m * 1e6,
                    check.join(" ")
                );
            }
            println!("octave-band levels, dB re 1 µm² (0.5 1 2 4 8 16 /mm):");
            for d in &derived {
                let o = surfaces::octave_db_of(&d.stats.band_db);
                let v: Vec<String> = o.iter().map(|v| format!("{v:6.1}")).collect();
                println!("{:15} {}", d.stats.name, v.join(" "));
            }
            if let Some(p) = out {
                std::fs::write(&p, surfaces::render_rust(&derived))
                    .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", p.display()))?;
                eprintln!("wrote {}", p.display());
            }
            Ok(())
        }
    }
}
