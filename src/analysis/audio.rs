//! Reading recordings for fitting: any PCM/float WAV that `hound` reads, as mono f64 in full-scale
//! units. Rejects inputs that would give meaningless fits with a one-line reason.

use std::path::Path;

/// Lowest sample rate accepted (Hz): below it the modes above ~10 kHz that carry metal and glass
/// timbre are lost (the recordings used here go down to 20 kHz).
pub const MIN_RATE_HZ: u32 = 20_000;
/// Highest sample rate accepted (Hz): above 192 kHz the fit only costs time (nothing audible).
pub const MAX_RATE_HZ: u32 = 192_000;

/// A mono recording.
#[derive(Debug, Clone)]
pub struct Recording {
    /// Samples in full-scale units (±1).
    pub samples: Vec<f64>,
    /// Sample rate in Hz.
    pub sample_rate: f64,
    /// Note on what was done to it (e.g. stereo mixed to mono), empty if nothing.
    pub note: String,
}

/// Reads a WAV file; errors are one line and name the file.
pub fn read_wav(path: &Path) -> anyhow::Result<Recording> {
    let name = path.display();
    let reader =
        hound::WavReader::open(path).map_err(|e| anyhow::anyhow!("{name}: not a readable WAV file ({e})"))?;
    let spec = reader.spec();
    if spec.sample_format == hound::SampleFormat::Int && spec.bits_per_sample <= 8 {
        anyhow::bail!(
            "{name}: 8-bit WAV is not supported (48 dB of dynamic range is too little to fit decays); convert to 16-bit or more"
        );
    }
    if spec.sample_rate < MIN_RATE_HZ || spec.sample_rate > MAX_RATE_HZ {
        anyhow::bail!(
            "{name}: sample rate {} Hz is outside the supported {MIN_RATE_HZ}..={MAX_RATE_HZ} Hz",
            spec.sample_rate
        );
    }
    let ch = spec.channels.max(1) as usize;
    let raw: Vec<f64> = match spec.sample_format {
        hound::SampleFormat::Float => reader
            .into_samples::<f32>()
            .map(|s| s.map(f64::from))
            .collect::<Result<_, _>>()
            .map_err(|e| anyhow::anyhow!("{name}: corrupt WAV data ({e})"))?,
        hound::SampleFormat::Int => {
            let scale = 1.0 / f64::from(1u32 << (spec.bits_per_sample - 1));
            reader
                .into_samples::<i32>()
                .map(|s| s.map(|v| f64::from(v) * scale))
                .collect::<Result<_, _>>()
                .map_err(|e| anyhow::anyhow!("{name}: corrupt WAV data ({e})"))?
        }
    };
    let samples: Vec<f64> = raw
        .chunks_exact(ch)
        .map(|c| c.iter().sum::<f64>() / ch as f64)
        .collect();
    let note = if ch > 1 {
        format!("{ch} channels mixed to mono")
    } else {
        String::new()
    };
    let rec = Recording {
        samples,
        sample_rate: f64::from(spec.sample_rate),
        note,
    };
    check_signal(&rec.samples, rec.sample_rate).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    Ok(rec)
}

/// Rejects empty, too short, silent, non-finite or clipped signals.
pub fn check_signal(x: &[f64], fs: f64) -> anyhow::Result<()> {
    if x.is_empty() {
        anyhow::bail!("the recording is empty");
    }
    if x.iter().any(|v| !v.is_finite()) {
        anyhow::bail!("the recording contains NaN or infinite samples");
    }
    if (x.len() as f64) < 0.02 * fs {
        anyhow::bail!(
            "the recording is too short ({:.1} ms; need at least 20 ms)",
            1e3 * x.len() as f64 / fs
        );
    }
    let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Why 1e-5 (−100 dBFS): below that a 16-bit file holds only dither.
    if peak < 1e-5 {
        anyhow::bail!(
            "the recording is silent (peak {:.1} dBFS)",
            20.0 * peak.max(1e-300).log10()
        );
    }
    // Clipping: runs of ≥ 3 consecutive samples pinned at full scale. Why: a single sample at
    // 0 dBFS happens in normalised files; a flat run only happens when the waveform was cut.
    let mut run = 0usize;
    let mut clipped = 0usize;
    for v in x {
        if v.abs() >= 0.9995 {
            run += 1;
            if run == 3 {
                clipped += 3;
            } else if run > 3 {
                clipped += 1;
            }
        } else {
            run = 0;
        }
    }
    if clipped > 0 {
        anyhow::bail!(
            "the recording is clipped ({clipped} samples in flat runs at full scale); decays and levels would be wrong"
        );
    }
    Ok(())
}
