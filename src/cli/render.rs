//! `tactus render`: a scene (or the embedded demo) to a stereo WAV file, with stems.

use super::batch::WavArgs;
use super::progress::Bar;
use std::path::PathBuf;
use tactus::engine::limiter::Limiter;
use tactus::scene::{self, Scene};
use tactus::wav::{self, WavFormat};

/// The arguments of `tactus render`.
#[derive(clap::Args)]
pub struct Args {
    /// Scene file; omit with --demo.
    pub scene: Option<PathBuf>,
    /// Render the embedded demo scene instead of a file.
    #[arg(long, conflicts_with = "scene")]
    pub demo: bool,
    /// Output WAV path.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write each object's own render to DIR/<object>.wav (a one-object scene's stem is
    /// DIR/object.wav).
    #[arg(long, value_name = "DIR")]
    pub stems: Option<PathBuf>,
    #[command(flatten)]
    pub wav: WavArgs,
}

/// `tactus render`.
pub fn run(a: Args) -> anyhow::Result<()> {
    let tactus::batch::Output {
        format,
        header,
        block,
        limit,
    } = a.wav.checked()?;
    let loaded = match (a.scene, a.demo) {
        (_, true) => Scene::parse(scene::DEMO_SCENE, None)?,
        (Some(path), false) => Scene::load(&path)?,
        (None, false) => anyhow::bail!("give a scene file or --demo"),
    };
    if let Some(dir) = &a.stems {
        std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
    }
    // Fail on an unwritable output before spending time rendering.
    super::check_writable(&a.output)?;
    let bar = Bar::new("rendering {bar:40} {percent:>3}% eta {eta}");
    let t0 = std::time::Instant::now();
    let sr = loaded.scene.sample_rate;
    let stems = &a.stems;
    let (mut l, mut r) = scene::render_objects(&loaded, block, &bar, |name, l, r| match stems {
        Some(dir) => {
            let name = if name.is_empty() { "object" } else { name };
            wav::write_stereo(&dir.join(format!("{name}.wav")), sr, l, r, format, header)
        }
        None => Ok(()),
    })?;
    bar.finish();
    if limit {
        // The mix only: stems stay each object's own render, so they still sum to the
        // unlimited mix.
        Limiter::new(sr as f64).process_stereo(&mut l, &mut r);
    }
    let secs = t0.elapsed().as_secs_f64();
    wav::write_stereo(&a.output, sr, &l, &r, format, header)?;
    let peak = l.iter().chain(&r).fold(0.0f32, |m, v| m.max(v.abs()));
    eprintln!(
        "wrote {} ({:.2} s of audio, peak {:.1} dBFS, rendered in {:.2} s = {:.0}x real time)",
        a.output.display(),
        loaded.scene.duration_s,
        20.0 * (peak.max(1e-12) as f64).log10(),
        secs,
        loaded.scene.duration_s / secs.max(1e-9)
    );
    if peak > 1.0 && format != WavFormat::Float32 {
        eprintln!(
            "warning: the render clips (peak above 0 dBFS); lower gain_db, use --limit or --format float32"
        );
    }
    Ok(())
}
