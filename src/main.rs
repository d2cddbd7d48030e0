//! `tactus`: offline rendering, batches of variations, fitting, evaluation and benchmarking from
//! the command line. This file parses the command line and dispatches to the command's file in
//! `src/cli/`; every error is one line and a non-zero exit.

mod cli;

use clap::{Parser, Subcommand};

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
    /// Render a scene (JSON, see README) to a stereo WAV file: the mix of its objects.
    Render(cli::render::Args),
    /// Render variations of a scene (a spec: seeds, sampled or gridded parameters; see
    /// docs/batch.md) or a JSON-lines file of scenes into a folder of WAVs with a manifest
    /// (manifest.jsonl and manifest.csv). Parallel, resumable (files already there are skipped),
    /// shardable (--shard I/N).
    Batch(cli::batch::Args),
    /// Merge the shard manifests of a batch folder (all of manifest-shard-I-of-N present) into
    /// manifest.jsonl and manifest.csv, byte-identical to an unsharded run's.
    MergeManifests(cli::merge::Args),
    /// Fit a material preset from recordings (WAV, FLAC, AIFF, Ogg Vorbis or MP3 files, or folders
    /// of them).
    Fit(cli::fit::Args),
    /// Evaluate presets against labelled recordings: features of the recordings and of N
    /// rendered draws per preset, a material classifier trained on the recordings (nearest
    /// family centre; the report names the families each preset's draws fall nearest), and each
    /// feature's draw median against the recordings' 10-90 % range (docs/evaluation.md).
    Eval(cli::eval::Args),
    /// Benchmark: run time against error for fixed scenes and levers (use a release build).
    /// Writes results.md and time_vs_error.svg to --out (default target/bench); only
    /// --update-docs writes the committed docs/bench/.
    Bench(cli::bench::Args),
    /// Inspect presets.
    Preset {
        #[command(subcommand)]
        command: cli::preset::Command,
    },
    /// The scraping and rolling surfaces: list them, or derive the measured ones' statistics.
    Surfaces {
        #[command(subcommand)]
        command: cli::surfaces::Command,
    },
    /// The measured materials and surfaces against the seed authors' data: classifiers'
    /// confusion matrices, spectrogram contact sheets (docs/measured.md).
    Measured {
        #[command(subcommand)]
        command: cli::measured::Command,
    },
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => cli::render::run(a),
        Command::Batch(a) => cli::batch::run(a),
        Command::MergeManifests(a) => cli::merge::run(a),
        Command::Fit(a) => cli::fit::run(a),
        Command::Eval(a) => cli::eval::run(a),
        Command::Bench(a) => cli::bench::run(a),
        Command::Preset { command } => cli::preset::run(command),
        Command::Surfaces { command } => cli::surfaces::run(command),
        Command::Measured { command } => cli::measured::run(command),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
