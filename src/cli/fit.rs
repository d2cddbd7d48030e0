//! `tactus fit`: recordings (or measured mode tables) to a preset, with a table of the files
//! fitted and left out.

use super::progress::Bar;
use std::path::PathBuf;
use tactus::fit::pool::preset::fitted_preset_json;
use tactus::fit::pool::Pooling;
use tactus::fit::run::{fit_files, fit_tables, inputs_are_tables, short_name, unwritable, FitOutcome};
use tactus::stats::median;

/// The arguments of `tactus fit`.
#[derive(clap::Args)]
pub struct Args {
    /// Recordings of one material, WAV, FLAC, AIFF, Ogg Vorbis or MP3 (known by their header), or
    /// folders of them (their files named .wav, .flac, .aif/.aiff/.aifc, .ogg/.oga or .mp3); or
    /// mode tables of one material (`.json` as PyImpact's, `.csv`/`.txt` lines
    /// `object,frequency_hz,level_db,t60_s`; docs/measured.md).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Material name, e.g. wood.
    #[arg(long)]
    pub material: String,
    /// Output preset JSON.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Modes per sampled object (capped by the fewest modes found in a recording).
    #[arg(long, default_value_t = tactus::fit::pool::DEFAULT_COUNT as u16, value_parser = clap::value_parser!(u16).range(2..=64))]
    pub modes: u16,
    /// Write SVG plots (extracted modes per file, damping fit, sampled vs measured
    /// distributions) into this folder.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Stop with an error when any recording cannot be fitted (default: leave it out and
    /// say why).
    #[arg(long)]
    pub strict: bool,
    /// Also fit a dense mode field (per-band counts, level and decay laws of the spectral
    /// peaks beyond each component's modes) to each recording with at least twice as many
    /// peaks as modes (docs/model.md "Dense mode field"), as the shipped Metal and cymbal
    /// presets are fitted. Off by default: a recording with fewer peaks (a bar, a block, a
    /// bell) gets no field, and on a cymbal it takes about 40 % of the fit's time.
    #[arg(long)]
    pub dense: bool,
    /// How recordings are grouped into object families; each recording becomes one mixture
    /// component centred on its own modes, weighted so that every family weighs the same
    /// (and every object within it, by the manifest's object_id), and its family sets the
    /// damping law and the size spread: auto (manifest.csv beside the files, else name), manifest
    /// (its `instrument` column), name (`<material>_<family>_….wav`), folder (one folder
    /// per family), none (one family).
    #[arg(long, default_value = "auto")]
    pub family_by: tactus::fit::pool::family::FamilyBy,
    /// Display name of the preset (default: the material, capitalised).
    #[arg(long)]
    pub name: Option<String>,
    /// Mode tables only: keep the first N objects of each table (1: the rows PyImpact draws
    /// an object from; default all).
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub table_objects: Option<u16>,
}

/// `tactus fit`.
pub fn run(a: Args) -> anyhow::Result<()> {
    let output = a.output.as_path();
    // Fail on an impossible output before minutes of fitting (without leaving an empty file
    // behind if the fit then fails).
    if let Some(why) = unwritable(output) {
        anyhow::bail!("cannot write {}: {why}", output.display());
    }
    let mut pooling = Pooling::new(&a.material)
        .family_by(a.family_by)
        .modes(usize::from(a.modes))
        .dense(a.dense);
    if let Some(name) = &a.name {
        pooling = pooling.named(name);
    }
    let t0 = std::time::Instant::now();
    let tables = inputs_are_tables(&a.inputs)?;
    if a.table_objects.is_some() && !tables {
        anyhow::bail!("--table-objects applies to mode tables, and the inputs are recordings");
    }
    let bar = Bar::new("fitting {bar:40} {pos}/{len} elapsed {elapsed} eta {eta}");
    let outcome = match tables {
        true => fit_tables(&a.inputs, &pooling, a.table_objects.map(usize::from), &bar),
        false => fit_files(&a.inputs, &pooling, a.strict, &bar),
    };
    bar.finish();
    let FitOutcome {
        results,
        left_out,
        notes,
        preset,
    } = outcome?;
    for n in &notes {
        eprintln!("note: {n}");
    }
    if tables {
        println!("{:<64} {:>6}", "table object", "modes");
        for r in &results {
            println!("{:<64} {:>6}", r.name, r.modes.len());
        }
        println!(
            "{} table objects pooled into {} famil{} in {:.1} s",
            results.len(),
            preset.families.len().max(1),
            if preset.families.len() > 1 { "ies" } else { "y" },
            t0.elapsed().as_secs_f64()
        );
        std::fs::write(output, fitted_preset_json(&preset) + "\n")
            .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", output.display()))?;
        eprintln!("wrote {}", output.display());
        return Ok(());
    }
    println!(
        "{:<64} {:>6} {:>9} {:>10}",
        "file", "modes", "attack ms", "ERB LSD dB"
    );
    for r in &results {
        println!(
            "{:<64} {:>6} {:>9.2} {:>10.2} {}",
            short_name(&r.name),
            r.modes.len(),
            1e3 * r.attack_s,
            r.distance_db,
            r.note
        );
    }
    for l in &left_out {
        println!("{:<64} left out: {}", l.name, l.reason);
    }
    let d: Vec<f64> = results.iter().map(|r| r.distance_db).collect();
    println!("median ERB-band log-spectral distance: {:.2} dB", median(&d));
    println!(
        "{} recording{} fitted, {} left out{} in {:.1} s",
        results.len(),
        if results.len() == 1 { "" } else { "s" },
        left_out.len(),
        if left_out.is_empty() {
            String::new()
        } else {
            format!(
                " ({})",
                left_out
                    .iter()
                    .map(|l| l.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        t0.elapsed().as_secs_f64()
    );
    std::fs::write(output, fitted_preset_json(&preset) + "\n")
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", output.display()))?;
    eprintln!("wrote {}", output.display());
    if let Some(dir) = &a.plot {
        let files = tactus::fit::plot::write_plots(dir, &results, &preset)?;
        eprintln!("wrote {} plots into {}", files.len(), dir.display());
    }
    Ok(())
}
