//! WAV output for the CLI: 16/24-bit PCM or 32-bit float, stereo.

use std::path::Path;

/// Sample format of written files.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum WavFormat {
    /// 16-bit PCM (clipped at full scale).
    Pcm16,
    /// 24-bit PCM (clipped at full scale).
    Pcm24,
    /// 32-bit IEEE float (no clipping).
    Float32,
}

/// Writes a stereo file. Errors name the path.
pub fn write_stereo(
    path: &Path,
    sample_rate: u32,
    left: &[f32],
    right: &[f32],
    format: WavFormat,
) -> anyhow::Result<()> {
    let (bits, fmt) = match format {
        WavFormat::Pcm16 => (16, hound::SampleFormat::Int),
        WavFormat::Pcm24 => (24, hound::SampleFormat::Int),
        WavFormat::Float32 => (32, hound::SampleFormat::Float),
    };
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate,
        bits_per_sample: bits,
        sample_format: fmt,
    };
    let ctx = |e: hound::Error| anyhow::anyhow!("cannot write {}: {e}", path.display());
    let mut w = hound::WavWriter::create(path, spec).map_err(ctx)?;
    let scale = ((1u32 << (bits - 1)) - 1) as f32;
    for (&l, &r) in left.iter().zip(right) {
        for v in [l, r] {
            match format {
                WavFormat::Float32 => w.write_sample(v).map_err(ctx)?,
                _ => w
                    .write_sample((v.clamp(-1.0, 1.0) * scale).round() as i32)
                    .map_err(ctx)?,
            }
        }
    }
    w.finalize().map_err(ctx)?;
    Ok(())
}
