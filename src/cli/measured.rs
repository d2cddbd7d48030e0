//! `tactus measured`: the measured materials and surfaces against their data (docs/measured.md):
//! the classifiers' confusion matrices, and the contact sheets of spectrograms.

use std::path::{Path, PathBuf};
use tactus::eval::{measured, surface_id};

/// Where the seed authors' data sit by default: beside the checkout, as in the docs.
const DEFAULT_DATA: &str = "../shared/measured";

/// The subcommands of `tactus measured`.
#[derive(clap::Subcommand)]
pub enum Command {
    /// Recognition of the measured materials (a nearest-centre classifier trained on the mode
    /// tables' own renderings judges them, each left out, and the presets' draws: 14-way and
    /// hard/soft) and of the measured surfaces (scrapes, 12-way and every pair); prints the
    /// confusion matrices as Markdown.
    Classify {
        /// Folder of the data (`materials/` with the mode tables).
        #[arg(long, default_value = DEFAULT_DATA)]
        data: PathBuf,
        /// Table renderings per material and size class.
        #[arg(long, default_value_t = 16)]
        renders: usize,
        /// Draws per material and size class.
        #[arg(long, default_value_t = 7)]
        draws: usize,
        /// Scrapes per surface.
        #[arg(long, default_value_t = 12)]
        scrapes: usize,
    },
    /// Write the contact sheets of spectrograms: each measured material's table rendering
    /// beside a draw (two PNGs) and a scrape on each measured surface (one PNG).
    Spectrograms {
        /// Folder of the data (`materials/` with the mode tables).
        #[arg(long, default_value = DEFAULT_DATA)]
        data: PathBuf,
        /// Output folder.
        #[arg(short, long)]
        out: PathBuf,
    },
}

fn materials_dir(data: &Path) -> anyhow::Result<PathBuf> {
    let dir = data.join("materials");
    if !dir.is_dir() {
        anyhow::bail!(
            "{}: no mode tables there (the seed authors' materials/ folder; --data)",
            dir.display()
        );
    }
    Ok(dir)
}

/// `tactus measured`.
pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Classify {
            data,
            renders,
            draws,
            scrapes,
        } => {
            if renders < 2 || scrapes < 2 {
                anyhow::bail!("--renders and --scrapes must be at least 2");
            }
            let sounds = measured::measure_all(&materials_dir(&data)?, renders, draws)?;
            let r = measured::recognition(&sounds);
            let pct = |c: &tactus::eval::confusion::Confusion| {
                format!("{:.1} % ({} of {})", 100.0 * c.share(), c.correct(), c.total())
            };
            println!(
                "Materials, 14-way: table renderings left out one at a time {}, the presets' draws {} (chance {:.1} %)",
                pct(&r.table_material),
                pct(&r.draws_material),
                100.0 / 14.0
            );
            println!(
                "Materials, hard/soft: table renderings left out one at a time {}, the presets' draws {}\n",
                pct(&r.table_hardness),
                pct(&r.draws_hardness)
            );
            println!(
                "Table renderings, left out one at a time:\n\n{}",
                r.table_material.markdown(measured::short_name)
            );
            println!(
                "The presets' draws:\n\n{}",
                r.draws_material.markdown(measured::short_name)
            );
            println!(
                "Hard/soft, table renderings left out:\n\n{}",
                r.table_hardness.markdown(str::to_owned)
            );
            println!(
                "Hard/soft, the presets' draws:\n\n{}",
                r.draws_hardness.markdown(str::to_owned)
            );
            let s = surface_id::recognise(scrapes);
            println!(
                "Surfaces, 12-way, each scrape left out: {} ({scrapes} scrapes per surface at {} m/s, {} N)\n",
                pct(&s.confusion),
                surface_id::SPEED_M_PER_S,
                surface_id::PRESSURE_N
            );
            println!("{}", s.confusion.markdown(str::to_owned));
            println!("| pair | largest audible octave-band difference, dB | told apart |\n|---|---:|---:|");
            for p in &s.pairs {
                println!(
                    "| {} / {} | {:.1} | {:.0} %{} |",
                    p.a.name(),
                    p.b.name(),
                    p.difference_db,
                    100.0 * p.share,
                    if p.difference_db > surface_id::DISTINCT_DB {
                        ""
                    } else {
                        " (not required)"
                    }
                );
            }
            Ok(())
        }
        Command::Spectrograms { data, out } => {
            std::fs::create_dir_all(&out)
                .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", out.display()))?;
            let mut files = measured::write_material_sheets(&materials_dir(&data)?, &out)?;
            files.push(surface_id::write_surface_sheet(&out)?);
            for f in files {
                println!("wrote {}", f.display());
            }
            Ok(())
        }
    }
}
