//! `tactus batch`: variations of a scene, or a JSON-lines file of scenes, into a folder of WAV
//! files with a manifest; and the WAV options `render` shares.

use super::progress::Bar;
use std::path::PathBuf;
use tactus::batch::{self, Batch, Shard};
use tactus::wav::{WavFormat, WavHeader};

/// The arguments of `tactus batch`.
#[derive(clap::Args)]
pub struct Args {
    /// Variation spec (JSON); omit with --scenes.
    #[arg(required_unless_present = "scenes")]
    pub spec: Option<PathBuf>,
    /// JSON-lines file: one scene per line (or a manifest row, whose "scene" is rendered).
    #[arg(long, conflicts_with = "spec")]
    pub scenes: Option<PathBuf>,
    /// Output folder (created if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Render only items i with i % N == I, writing manifest-shard-I-of-N.{jsonl,csv}
    /// (merge with `tactus merge-manifests`).
    #[arg(long, value_name = "I/N")]
    pub shard: Option<Shard>,
    /// Worker threads (default: one per core).
    #[arg(long)]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub wav: WavArgs,
}

/// How WAV files are written (render and batch).
#[derive(clap::Args)]
pub struct WavArgs {
    /// Sample format.
    #[arg(long, value_enum, default_value = "pcm24")]
    pub format: WavFormat,
    /// Header layout: plain (WAVEFORMAT, opened by every reader, Python's wave module included)
    /// or extensible (WAVE_FORMAT_EXTENSIBLE).
    #[arg(long, value_enum, default_value = "plain")]
    pub wav_header: WavHeader,
    /// Processing block size in samples, 1..=8192. Samples differ between block sizes by at
    /// most 1e-5 of full scale (-100 dBFS; f32 rounding where blocks split the bank's steps).
    #[arg(long, default_value_t = 256)]
    pub block: usize,
    /// Pass the output through the plugin's limiter: no sample above -0.3 dBFS, material
    /// under it bit-identical, no delay. Off by default: the render is the unlimited float
    /// signal (peaks above 0 dBFS kept with --format float32).
    #[arg(long)]
    pub limit: bool,
}

impl WavArgs {
    /// The output settings, the block size checked.
    pub fn checked(&self) -> anyhow::Result<batch::Output> {
        batch::check_block(self.block).map_err(|e| anyhow::anyhow!("--block {e}"))?;
        Ok(batch::Output {
            format: self.format,
            header: self.wav_header,
            block: self.block,
            limit: self.limit,
        })
    }
}

/// `tactus batch`.
pub fn run(a: Args) -> anyhow::Result<()> {
    let out = a.wav.checked()?;
    let b = match (a.spec, a.scenes) {
        (Some(spec), None) => Batch::from_spec(&spec, out)?,
        (None, Some(lines)) => Batch::from_lines(&lines, out)?,
        _ => anyhow::bail!("give a spec file or --scenes FILE"),
    };
    let shard = a.shard.unwrap_or(Shard::ALL);
    fixed_malloc_thresholds();
    let t0 = std::time::Instant::now();
    let bar = Bar::new("{pos}/{len} {bar:40} {percent:>3}% eta {eta}");
    let s = batch::run(&b, &a.output, out, shard, a.threads, &bar);
    bar.finish();
    let s = s?;
    eprintln!(
        "{}: {} rendered, {} already there, of {} items in shard {}/{}; {}.jsonl + .csv ({:.1} s)",
        a.output.display(),
        s.rendered,
        s.skipped,
        s.rendered + s.skipped,
        shard.index,
        shard.count,
        batch::manifest_stem(shard),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
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
