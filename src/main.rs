//! `tactus`: offline rendering, batches of variations, fitting and benchmarking from the command
//! line. A thin layer over the engine; every error is one line and a non-zero exit.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use tactus::batch::{self, Batch, Shard};
use tactus::scene::{self, Scene};
use tactus::wav::{self, WavFormat, WavHeader};

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
    Render {
        /// Scene file; omit with --demo.
        scene: Option<PathBuf>,
        /// Render the embedded demo scene instead of a file.
        #[arg(long, conflicts_with = "scene")]
        demo: bool,
        /// Output WAV path.
        #[arg(short, long)]
        output: PathBuf,
        /// Also write each object's own render to DIR/<object>.wav (a one-object scene's stem is
        /// DIR/object.wav).
        #[arg(long, value_name = "DIR")]
        stems: Option<PathBuf>,
        #[command(flatten)]
        wav: WavArgs,
    },
    /// Render variations of a scene (a spec: seeds, sampled or gridded parameters; see
    /// docs/batch.md) or a JSON-lines file of scenes into a folder of WAVs with a manifest
    /// (manifest.jsonl and manifest.csv). Parallel, resumable (files already there are skipped),
    /// shardable (--shard I/N).
    Batch {
        /// Variation spec (JSON); omit with --scenes.
        #[arg(required_unless_present = "scenes")]
        spec: Option<PathBuf>,
        /// JSON-lines file: one scene per line (or a manifest row, whose "scene" is rendered).
        #[arg(long, conflicts_with = "spec")]
        scenes: Option<PathBuf>,
        /// Output folder (created if missing).
        #[arg(short, long)]
        output: PathBuf,
        /// Render only items i with i % N == I, writing manifest-shard-I-of-N.{jsonl,csv}
        /// (merge with `tactus merge-manifests`).
        #[arg(long, value_name = "I/N")]
        shard: Option<Shard>,
        /// Worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
        #[command(flatten)]
        wav: WavArgs,
    },
    /// Merge the shard manifests of a batch folder (all of manifest-shard-I-of-N present) into
    /// manifest.jsonl and manifest.csv, byte-identical to an unsharded run's.
    MergeManifests {
        /// Batch output folder holding the shards' manifests.
        dir: PathBuf,
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
        #[arg(long, default_value_t = tactus::fit::cli::DEFAULT_COUNT as u16, value_parser = clap::value_parser!(u16).range(2..=64))]
        modes: u16,
        /// Write SVG plots (extracted modes per file, damping fit, sampled vs measured
        /// distributions) into this folder.
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Stop with an error when any recording cannot be fitted (default: leave it out and
        /// say why).
        #[arg(long)]
        strict: bool,
        /// Also fit a dense mode field (per-band counts, level and decay laws of the spectral
        /// peaks beyond each component's modes) to each recording with at least twice as many
        /// peaks as modes (docs/model.md "Dense mode field"). Off by default: on the recordings
        /// measured so far its draws count fewer peaks, and ring and attack less like the
        /// recordings, than draws without it (docs/presets.md, "Alternatives considered").
        #[arg(long)]
        dense: bool,
        /// How recordings are grouped into object families; each recording becomes one mixture
        /// component centred on its own modes, weighted so that every family weighs the same
        /// (and every object within it, by the manifest's object_id), and its family sets the
        /// damping law and the size spread: auto (manifest.csv beside the files, else name), manifest
        /// (its `instrument` column), name (`<material>_<family>_….wav`), folder (one folder
        /// per family), none (one family).
        #[arg(long, default_value = "auto")]
        family_by: tactus::fit::family::FamilyBy,
        /// Display name of the preset (default: the material, capitalised).
        #[arg(long)]
        name: Option<String>,
    },
    /// Evaluate presets against labelled recordings: features of the recordings and of N
    /// rendered draws per preset, a material classifier trained on the recordings (nearest
    /// family centre; the report names the families each preset's draws fall nearest), and each
    /// feature's draw median against the recordings' 10-90 % range (docs/evaluation.md).
    #[command(group(clap::ArgGroup::new("leave_one_out").args(["leave_family_out", "leave_kit_out"])))]
    Eval {
        /// Folders of recordings labelled by manifest.csv (columns file, material, instrument)
        /// or by names <material>_<family>_....wav; the classifier is trained on all of them.
        #[arg(required = true)]
        recordings: Vec<PathBuf>,
        /// Preset to evaluate: a built-in name or a preset .json file; repeatable. Default:
        /// every built-in fitted preset.
        #[arg(long = "preset")]
        presets: Vec<String>,
        /// Instead of judging presets: for each family of this material, fit the material from
        /// the recordings of all other families and judge its draws against the held-out
        /// family (recognition, feature ranges, a real-vs-synthetic discriminator, velocity
        /// layers).
        #[arg(long, value_name = "MATERIAL", conflicts_with_all = ["presets", "spectrograms"])]
        leave_family_out: Option<String>,
        /// Instead of judging presets: for each kit (drum kit or sound bank: the manifest's
        /// `kit`, else the third `_` field of `<material>_<family>_<kit>_....wav`) among this
        /// family's recordings, fit the family from the other kits' recordings and judge its
        /// draws against the held-out kit's (as --leave-family-out does).
        #[arg(
            long,
            value_name = "FAMILY",
            conflicts_with_all = ["presets", "spectrograms", "leave_family_out"]
        )]
        leave_kit_out: Option<String>,
        /// With --leave-family-out or --leave-kit-out: fit as `tactus fit --dense` does, with a
        /// dense mode field for each recording whose counted peaks are at least twice its modes
        /// (cymbals).
        #[arg(long, requires = "leave_one_out")]
        dense: bool,
        /// Draws (new objects, seeds 1..=N) per preset.
        #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=10_000))]
        draws: u32,
        /// Also write the whole report as JSON to this file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Write one PNG per preset into this folder: a recording's spectrogram beside three
        /// draws'.
        #[arg(long)]
        spectrograms: Option<PathBuf>,
    },
    /// Benchmark: run time against error for fixed scenes and levers (use a release build).
    /// Writes results.md and time_vs_error.svg to --out (default target/bench); only
    /// --update-docs writes the committed docs/bench/.
    Bench {
        /// Short run (< 60 s) for CI smoke tests.
        #[arg(long)]
        quick: bool,
        /// Output folder for results.md and time_vs_error.svg.
        #[arg(long, default_value = tactus::bench::DEFAULT_OUT, conflicts_with = "update_docs")]
        out: PathBuf,
        /// Write to docs/bench/ (the committed results the README quotes) instead of --out.
        #[arg(long)]
        update_docs: bool,
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

/// How WAV files are written (render and batch).
#[derive(clap::Args)]
struct WavArgs {
    /// Sample format.
    #[arg(long, value_enum, default_value = "pcm24")]
    format: WavFormat,
    /// Header layout: plain (WAVEFORMAT, opened by every reader, Python's wave module included)
    /// or extensible (WAVE_FORMAT_EXTENSIBLE).
    #[arg(long, value_enum, default_value = "plain")]
    wav_header: WavHeader,
    /// Processing block size in samples, 1..=8192. Samples differ between block sizes by at
    /// most 1e-5 of full scale (-100 dBFS; f32 rounding where blocks split the bank's steps).
    #[arg(long, default_value_t = 256)]
    block: usize,
}

impl WavArgs {
    fn checked(&self) -> anyhow::Result<batch::Output> {
        if !(1..=8192).contains(&self.block) {
            anyhow::bail!("--block must be in 1..=8192, got {}", self.block);
        }
        Ok(batch::Output {
            format: self.format,
            header: self.wav_header,
            block: self.block,
        })
    }
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
        Command::Bench {
            quick,
            out,
            update_docs,
            only,
        } => {
            let out = if update_docs {
                PathBuf::from(tactus::bench::DOCS_OUT)
            } else {
                out
            };
            tactus::bench::run(quick, &out, only.as_deref())
        }
        Command::Batch {
            spec,
            scenes,
            output,
            shard,
            threads,
            wav,
        } => {
            let out = wav.checked()?;
            let b = match (spec, scenes) {
                (Some(spec), None) => Batch::from_spec(&spec, out)?,
                (None, Some(lines)) => Batch::from_lines(&lines, out)?,
                _ => anyhow::bail!("give a spec file or --scenes FILE"),
            };
            let shard = shard.unwrap_or(Shard::ALL);
            fixed_malloc_thresholds();
            let t0 = std::time::Instant::now();
            let s = batch::run(&b, &output, out, shard, threads, std::io::stderr().is_terminal())?;
            let manifest = if shard.count == 1 {
                "manifest".to_string()
            } else {
                format!("manifest-shard-{}-of-{}", shard.index, shard.count)
            };
            eprintln!(
                "{}: {} rendered, {} already there, of {} items in shard {}/{}; {manifest}.jsonl + .csv ({:.1} s)",
                output.display(),
                s.rendered,
                s.skipped,
                s.rendered + s.skipped,
                shard.index,
                shard.count,
                t0.elapsed().as_secs_f64()
            );
            Ok(())
        }
        Command::MergeManifests { dir } => {
            let rows = batch::merge_manifests(&dir)?;
            eprintln!(
                "{}: merged {rows} rows into manifest.jsonl + manifest.csv",
                dir.display()
            );
            Ok(())
        }
        Command::Fit {
            inputs,
            material,
            output,
            modes,
            plot,
            strict,
            dense,
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
            strict,
            dense,
        ),
        Command::Eval {
            recordings,
            presets,
            leave_family_out,
            leave_kit_out,
            dense,
            draws,
            json,
            spectrograms,
        } => {
            use tactus::eval::lofo::{self, HoldOut};
            let held_out = match (leave_family_out, leave_kit_out) {
                (Some(material), _) => Some((HoldOut::Family, material)),
                (None, Some(family)) => Some((HoldOut::Kit, family)),
                (None, None) => None,
            };
            match held_out {
                Some((held_out, of)) => {
                    lofo::run(&recordings, held_out, &of, draws as usize, dense, json.as_deref())
                }
                None => tactus::eval::run(
                    &recordings,
                    &presets,
                    draws as usize,
                    json.as_deref(),
                    spectrograms.as_deref(),
                ),
            }
        }
        Command::Preset {
            command: PresetCommand::Show { preset },
        } => tactus::fit::cli::run_show(&preset),
        Command::Render {
            scene,
            demo,
            output,
            stems,
            wav: wav_args,
        } => {
            let batch::Output {
                format,
                header,
                block,
            } = wav_args.checked()?;
            let loaded = match (scene, demo) {
                (_, true) => Scene::parse(scene::DEMO_SCENE, None)?,
                (Some(path), false) => Scene::load(&path)?,
                (None, false) => anyhow::bail!("give a scene file or --demo"),
            };
            if let Some(dir) = &stems {
                std::fs::create_dir_all(dir)
                    .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
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
            let sr = loaded.scene.sample_rate;
            let (l, r) = scene::render_objects(
                &loaded,
                block,
                |f| {
                    if let Some(b) = &bar {
                        b.set_position((f * 1000.0) as u64);
                    }
                },
                |name, l, r| match &stems {
                    Some(dir) => {
                        let name = if name.is_empty() { "object" } else { name };
                        wav::write_stereo(&dir.join(format!("{name}.wav")), sr, l, r, format, header)
                    }
                    None => Ok(()),
                },
            )?;
            if let Some(b) = bar {
                b.finish_and_clear();
            }
            let secs = t0.elapsed().as_secs_f64();
            wav::write_stereo(&output, sr, &l, &r, format, header)?;
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

/// Fixes glibc malloc's mmap and trim thresholds at 64 KiB for a batch. By default glibc raises
/// both adaptively after freeing large blocks, and with worker threads the freed render buffers
/// then stay in the heap: peak memory crept up by about 1.3 KB per rendered item. Fixed
/// thresholds return those buffers to the system, so peak memory does not depend on the batch
/// size (docs/batch.md, "Speed and memory"). Environment settings of the same thresholds win.
fn fixed_malloc_thresholds() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        let set_by_user = |name: &str| std::env::var_os(name).is_some();
        // SAFETY: mallopt only changes allocator tunables; it is called before the worker
        // threads start.
        unsafe {
            if !set_by_user("MALLOC_MMAP_THRESHOLD_") {
                libc::mallopt(libc::M_MMAP_THRESHOLD, 64 * 1024);
            }
            if !set_by_user("MALLOC_TRIM_THRESHOLD_") {
                libc::mallopt(libc::M_TRIM_THRESHOLD, 64 * 1024);
            }
        }
    }
}
