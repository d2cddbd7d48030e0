//! WAV output for the CLI: 16/24-bit PCM or 32-bit float, stereo.
//!
//! Two header layouts. `plain` (the default) is the original WAVEFORMAT header (format tag 1 for
//! PCM, 3 for float, 16-byte `fmt ` chunk): every WAV reader opens it, including Python's `wave`
//! module (which reads PCM only, up to Python 3.11 not WAVE_FORMAT_EXTENSIBLE). `extensible` is
//! WAVE_FORMAT_EXTENSIBLE, which Microsoft's spec asks for above 16 bits; soundfile/libsndfile,
//! sox, ffmpeg, scipy and hound read both.

use std::io::Write;
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

/// Header layout of written files (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum WavHeader {
    /// WAVEFORMAT (tag 1 = PCM, 3 = float): opened by every reader, Python's `wave` included.
    #[default]
    Plain,
    /// WAVE_FORMAT_EXTENSIBLE (for 24-bit and float; 16-bit stays plain).
    Extensible,
}

impl WavFormat {
    fn bits(self) -> u16 {
        match self {
            WavFormat::Pcm16 => 16,
            WavFormat::Pcm24 => 24,
            WavFormat::Float32 => 32,
        }
    }

    /// The stored sample of `v` (PCM: clipped to full scale, rounded), as little-endian bytes
    /// in the first `bits / 8` bytes.
    fn encode(self, v: f32) -> [u8; 4] {
        match self {
            WavFormat::Float32 => v.to_le_bytes(),
            _ => {
                let scale = ((1u32 << (self.bits() - 1)) - 1) as f32;
                ((v.clamp(-1.0, 1.0) * scale).round() as i32).to_le_bytes()
            }
        }
    }
}

/// Writes a stereo file. Errors name the path.
pub fn write_stereo(
    path: &Path,
    sample_rate: u32,
    left: &[f32],
    right: &[f32],
    format: WavFormat,
    header: WavHeader,
) -> anyhow::Result<()> {
    let ctx = |e: &dyn std::fmt::Display| anyhow::anyhow!("cannot write {}: {e}", path.display());
    let frames = left.len().min(right.len());
    let bytes = u64::from(format.bits() / 8);
    let data_bytes = frames as u64 * 2 * bytes;
    // RIFF sizes are 32-bit: the data plus the 36 header bytes that follow the size field.
    if data_bytes + 36 > u64::from(u32::MAX) {
        anyhow::bail!(
            "cannot write {}: {frames} stereo frames of {}-bit audio exceed the 4 GiB WAV limit; use a lower sample rate or a shorter scene",
            path.display(),
            format.bits()
        );
    }
    if header == WavHeader::Extensible {
        return write_hound(path, sample_rate, &left[..frames], &right[..frames], format)
            .map_err(|e| ctx(&e));
    }
    let file = std::fs::File::create(path).map_err(|e| ctx(&e))?;
    let mut w = std::io::BufWriter::new(file);
    let tag: u16 = if format == WavFormat::Float32 { 3 } else { 1 };
    let block_align = 2 * format.bits() / 8;
    let mut head = Vec::with_capacity(44);
    head.extend_from_slice(b"RIFF");
    head.extend_from_slice(&((data_bytes + 36) as u32).to_le_bytes());
    head.extend_from_slice(b"WAVEfmt ");
    head.extend_from_slice(&16u32.to_le_bytes());
    head.extend_from_slice(&tag.to_le_bytes());
    head.extend_from_slice(&2u16.to_le_bytes());
    head.extend_from_slice(&sample_rate.to_le_bytes());
    head.extend_from_slice(&(sample_rate * u32::from(block_align)).to_le_bytes());
    head.extend_from_slice(&block_align.to_le_bytes());
    head.extend_from_slice(&format.bits().to_le_bytes());
    head.extend_from_slice(b"data");
    head.extend_from_slice(&(data_bytes as u32).to_le_bytes());
    w.write_all(&head).map_err(|e| ctx(&e))?;
    let n = bytes as usize;
    for (&l, &r) in left.iter().zip(right) {
        w.write_all(&format.encode(l)[..n]).map_err(|e| ctx(&e))?;
        w.write_all(&format.encode(r)[..n]).map_err(|e| ctx(&e))?;
    }
    w.flush().map_err(|e| ctx(&e))?;
    Ok(())
}

/// WAVE_FORMAT_EXTENSIBLE through hound, which picks it above 16 bits.
fn write_hound(
    path: &Path,
    sample_rate: u32,
    left: &[f32],
    right: &[f32],
    format: WavFormat,
) -> hound::Result<()> {
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate,
        bits_per_sample: format.bits(),
        sample_format: if format == WavFormat::Float32 {
            hound::SampleFormat::Float
        } else {
            hound::SampleFormat::Int
        },
    };
    let mut w = hound::WavWriter::create(path, spec)?;
    let scale = ((1u32 << (format.bits() - 1)) - 1) as f32;
    for (&l, &r) in left.iter().zip(right) {
        for v in [l, r] {
            match format {
                WavFormat::Float32 => w.write_sample(v)?,
                _ => w.write_sample((v.clamp(-1.0, 1.0) * scale).round() as i32)?,
            }
        }
    }
    w.finalize()
}

/// Peak and RMS (full scale = 1) over both channels of a WAV file as stored (after PCM
/// rounding), so a file's figures are the same whether it was just written or found on disk.
pub fn file_peak_rms(path: &Path) -> anyhow::Result<(f64, f64, f64)> {
    let ctx = |e: hound::Error| anyhow::anyhow!("cannot read {}: {e}", path.display());
    let mut r = hound::WavReader::open(path).map_err(ctx)?;
    let spec = r.spec();
    let (mut peak, mut sum, mut n) = (0.0f64, 0.0f64, 0u64);
    let mut add = |v: f64| {
        peak = peak.max(v.abs());
        sum += v * v;
        n += 1;
    };
    match spec.sample_format {
        hound::SampleFormat::Float => {
            for s in r.samples::<f32>() {
                add(f64::from(s.map_err(ctx)?));
            }
        }
        hound::SampleFormat::Int => {
            let scale = f64::from((1u32 << (spec.bits_per_sample - 1)) - 1);
            for s in r.samples::<i32>() {
                add(f64::from(s.map_err(ctx)?) / scale);
            }
        }
    }
    let frames = n / u64::from(spec.channels.max(1));
    let duration_s = frames as f64 / f64::from(spec.sample_rate);
    Ok((duration_s, peak, (sum / n.max(1) as f64).sqrt()))
}
