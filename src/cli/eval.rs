//! `tactus eval`: presets judged against labelled recordings, or a material (family) judged by
//! leaving one family (kit) out.

use super::progress::Bar;
use std::path::PathBuf;
use tactus::eval::leave_out::{self, table, HoldOut};
use tactus::eval::{self as ev, report, spectrogram};

/// The arguments of `tactus eval`.
#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("leave_one_out").args(["leave_family_out", "leave_kit_out"])))]
pub struct Args {
    /// Folders of recordings (WAV, FLAC, AIFF, Ogg Vorbis or MP3) labelled by manifest.csv
    /// (columns file, material, instrument) or by names <material>_<family>_....wav; the
    /// classifier is trained on all of them.
    #[arg(required = true)]
    pub recordings: Vec<PathBuf>,
    /// Preset to evaluate: a built-in name or a preset .json file; repeatable. Default:
    /// every built-in fitted preset.
    #[arg(long = "preset")]
    pub presets: Vec<String>,
    /// Instead of judging presets: for each family of this material, fit the material from
    /// the recordings of all other families and judge its draws against the held-out
    /// family (recognition, feature ranges, a real-vs-synthetic discriminator, velocity
    /// layers).
    #[arg(long, value_name = "MATERIAL", conflicts_with_all = ["presets", "spectrograms"])]
    pub leave_family_out: Option<String>,
    /// Instead of judging presets: for each kit (drum kit or sound bank: the manifest's
    /// `kit`, else the third `_` field of `<material>_<family>_<kit>_....wav`) among this
    /// family's recordings, fit the family from the other kits' recordings and judge its
    /// draws against the held-out kit's (as --leave-family-out does).
    #[arg(
        long,
        value_name = "FAMILY",
        conflicts_with_all = ["presets", "spectrograms", "leave_family_out"]
    )]
    pub leave_kit_out: Option<String>,
    /// With --leave-family-out or --leave-kit-out: fit as `tactus fit --dense` does, with a
    /// dense mode field for each recording whose counted peaks are at least twice its modes
    /// (cymbals).
    #[arg(long, requires = "leave_one_out")]
    pub dense: bool,
    /// Draws (new objects, seeds 1..=N) per preset.
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    pub draws: u32,
    /// Instead of judging presets against their family: draw each component of each preset's
    /// mixture alone (one per fitted recording) and compare the draws' feature medians with
    /// that recording's features, with each preset's median log ratio (bias) and its median
    /// magnitude (error).
    #[arg(long, conflicts_with_all = ["spectrograms", "leave_family_out", "leave_kit_out"])]
    pub components: bool,
    /// Also write the whole report as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write one PNG per preset into this folder: a recording's spectrogram beside three
    /// draws'.
    #[arg(long)]
    pub spectrograms: Option<PathBuf>,
}

/// `tactus eval`.
pub fn run(a: Args) -> anyhow::Result<()> {
    let held_out = match (&a.leave_family_out, &a.leave_kit_out) {
        (Some(material), _) => Some((HoldOut::Family, material.clone())),
        (None, Some(family)) => Some((HoldOut::Kit, family.clone())),
        (None, None) => None,
    };
    match held_out {
        Some((held_out, of)) => run_leave_out(&a, held_out, &of),
        None if a.components => run_components(&a),
        None => run_presets(&a),
    }
}

/// `tactus eval --components`.
fn run_components(a: &Args) -> anyhow::Result<()> {
    let presets = ev::resolve_presets(&a.presets)?;
    if let Some(p) = &a.json {
        super::check_writable(p)?;
    }
    let bar = Bar::new("evaluating components {bar:40} {pos}/{len} ({msg}) eta {eta}");
    let report = ev::components::evaluate_components(&a.recordings, &presets, a.draws as usize, &bar);
    bar.finish();
    let report = report?;
    if report.iter().all(|r| r.components.is_empty()) {
        anyhow::bail!(
            "no component of {} names a recording found in {}",
            presets
                .iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            a.recordings
                .iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    super::emit(
        |out| ev::components::write_table(out, &report),
        a.json.as_deref(),
        &report,
    )
}

/// `tactus eval` of presets.
fn run_presets(a: &Args) -> anyhow::Result<()> {
    let draws = a.draws as usize;
    if draws == 0 {
        anyhow::bail!("--draws must be at least 1");
    }
    let presets = ev::resolve_presets(&a.presets)?;
    if presets.is_empty() {
        anyhow::bail!("no presets to evaluate (no built-in fitted presets; give --preset)");
    }
    // Fail on unwritable outputs before minutes of work.
    if let Some(p) = &a.json {
        super::check_writable(p)?;
    }
    if let Some(d) = &a.spectrograms {
        std::fs::create_dir_all(d).map_err(|e| anyhow::anyhow!("cannot create {}: {e}", d.display()))?;
    }
    let bar = Bar::new("evaluating {bar:40} {pos}/{len} ({msg}) eta {eta}");
    if !bar.visible() {
        let (labels, _) = ev::label_folders(&a.recordings)?;
        eprintln!(
            "evaluating {} recordings and {} draws of {} presets",
            labels.len(),
            presets.len() * draws,
            presets.len()
        );
    }
    let report = ev::evaluate(&a.recordings, &presets, draws, &bar);
    bar.finish();
    let report = report?;
    super::emit(
        |out| report::write_table(out, &report),
        a.json.as_deref(),
        &report,
    )?;
    if let Some(d) = &a.spectrograms {
        for (preset, pr) in presets.iter().zip(&report.presets) {
            let path = d.join(format!("{}.png", spectrogram::slug(&preset.name)));
            let members = pr.reference.members(&report.recordings);
            let Some(rec) = ev::representative(&members) else {
                eprintln!("{}: no recording of its {} to show", preset.name, pr.reference);
                continue;
            };
            spectrogram::write_comparison(&path, &rec.label.path, preset)?;
            eprintln!("wrote {} ({} beside draws 1-3)", path.display(), rec.label.name);
        }
    }
    Ok(())
}

/// `tactus eval --leave-family-out MATERIAL` and `--leave-kit-out FAMILY`.
fn run_leave_out(a: &Args, held_out: HoldOut, of: &str) -> anyhow::Result<()> {
    let draws = a.draws as usize;
    if draws < 2 {
        anyhow::bail!("--draws must be at least 2 for --leave-{}-out", held_out.word());
    }
    if let Some(p) = &a.json {
        super::check_writable(p)?;
    }
    let bar = Bar::new("{spinner} {pos} measured ({msg}) {elapsed}").heartbeat();
    if !bar.visible() {
        eprintln!(
            "leave one {} out: fitting and judging '{of}' on {} folder(s)",
            held_out.word(),
            a.recordings.len()
        );
    }
    let report = leave_out::leave_one_out(&a.recordings, held_out, of, draws, a.dense, &bar);
    bar.finish();
    let report = report?;
    super::emit(
        |out| table::write_table(out, &report),
        a.json.as_deref(),
        &(&report, table::summarise(&report)),
    )
}
