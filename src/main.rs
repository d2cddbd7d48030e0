//! `tactus`: offline rendering (and, as the project grows, fitting and benchmarking) from the
//! command line. A thin layer over the engine; every error is one line and a non-zero exit.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use tactus::scene::{self, Scene};
use tactus::wav::{self, WavFormat};

#[derive(Parser)]
#[command(
    name = "tactus",
    version,
    about = "Physically based contact sounds: impacts, scraping, rolling"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (JSON, see README) to a stereo WAV file.
    Render {
        /// Scene file; omit with --demo.
        scene: Option<PathBuf>,
        /// Render the embedded demo scene instead of a file.
        #[arg(long, conflicts_with = "scene")]
        demo: bool,
        /// Output WAV path.
        #[arg(short, long)]
        output: PathBuf,
        /// Sample format.
        #[arg(long, value_enum, default_value = "pcm24")]
        format: WavFormat,
        /// Processing block size in samples (output does not depend on it).
        #[arg(long, default_value_t = 256)]
        block: usize,
    },
    /// Fit a material preset from recordings (WAV files or folders of them).
    Fit {
        /// Recordings or folders of recordings of one material.
        #[arg(required = true)]
        inputs: Vec<PathBuf>,
        /// Material name, e.g. wood.
        #[arg(long)]
        material: String,
        /// Output preset JSON.
        #[arg(short, long)]
        output: PathBuf,
        /// Modes per sampled object (capped by the fewest modes found in a recording).
        #[arg(long, default_value_t = 24, value_parser = clap::value_parser!(u16).range(2..=64))]
        modes: u16,
        /// Write SVG plots (extracted modes per file, damping fit, sampled vs measured
        /// distributions) into this folder.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// How recordings are grouped into object families, each fitted on its own and drawn
        /// by weight: auto (manifest.csv beside the files, else name), manifest (its
        /// `instrument` column), name (`<material>_<family>_….wav`), folder (one folder per
        /// family), none (one distribution).
        #[arg(long, default_value = "auto")]
        family_by: tactus::fit::family::FamilyBy,
        /// Display name of the preset (default: the material, capitalised).
        #[arg(long)]
        name: Option<String>,
    },
    /// Benchmark: run time against error for fixed scenes and levers (use a release build).
    Bench {
        /// Short run (< 60 s) for CI smoke tests.
        #[arg(long)]
        quick: bool,
        /// Output folder for results.md and time_vs_error.svg.
        #[arg(long, default_value = "docs/bench")]
        out: PathBuf,
        /// Only rows whose scene name contains this text (case-insensitive); prints them and
        /// writes nothing (for profiling one scene).
        #[arg(long)]
        only: Option<String>,
    },
    /// Inspect presets.
    Preset {
        #[command(subcommand)]
        command: PresetCommand,
    },
}

#[derive(Subcommand)]
enum PresetCommand {
    /// Validate a preset file and print its statistics.
    Show {
        /// Preset JSON file.
        preset: PathBuf,
    },
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Bench { quick, out, only } => tactus::bench::run(quick, &out, only.as_deref()),
        Command::Fit {
            inputs,
            material,
            output,
            modes,
            plot,
            family_by,
            name,
        } => tactus::fit::cli::run_fit(
            &inputs,
            &material,
            &output,
            usize::from(modes),
            plot.as_deref(),
            family_by,
            name.as_deref(),
        ),
        Command::Preset {
            command: PresetCommand::Show { preset },
        } => tactus::fit::cli::run_show(&preset),
        Command::Render {
            scene,
            demo,
            output,
            format,
            block,
        } => {
            let loaded = match (scene, demo) {
                (_, true) => Scene::parse(scene::DEMO_SCENE, None)?,
                (Some(path), false) => Scene::load(&path)?,
                (None, false) => anyhow::bail!("give a scene file or --demo"),
            };
            if !(1..=8192).contains(&block) {
                anyhow::bail!("--block must be in 1..=8192, got {block}");
            }
            // Fail on an unwritable output before spending time rendering.
            std::fs::File::create(&output)
                .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", output.display()))?;
            let bar = if std::io::stderr().is_terminal() {
                let b = ProgressBar::new(1000);
                b.set_style(
                    ProgressStyle::with_template("rendering {bar:40} {percent:>3}% eta {eta}")
                        .expect("valid template"),
                );
                Some(b)
            } else {
                None
            };
            let t0 = std::time::Instant::now();
            let (l, r) = scene::render(&loaded, block, |f| {
                if let Some(b) = &bar {
                    b.set_position((f * 1000.0) as u64);
                }
            });
            if let Some(b) = bar {
                b.finish_and_clear();
            }
            let secs = t0.elapsed().as_secs_f64();
            wav::write_stereo(&output, loaded.scene.sample_rate, &l, &r, format)?;
            let peak = l.iter().chain(&r).fold(0.0f32, |m, v| m.max(v.abs()));
            eprintln!(
                "wrote {} ({:.2} s of audio, peak {:.1} dBFS, rendered in {:.2} s = {:.0}x real time)",
                output.display(),
                loaded.scene.duration_s,
                20.0 * (peak.max(1e-12) as f64).log10(),
                secs,
                loaded.scene.duration_s / secs.max(1e-9)
            );
            if peak > 1.0 && format != WavFormat::Float32 {
                eprintln!(
                    "warning: the render clips (peak above 0 dBFS); lower gain_db or use --format float32"
                );
            }
            Ok(())
        }
    }
}
