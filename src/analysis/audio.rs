//! Reading recordings for fitting and evaluation, the one reader every caller goes through (the
//! CLI's fit and eval, the Python module, the plugin editor's fit): WAV through `hound` (PCM or
//! float), FLAC, AIFF, Ogg Vorbis and MP3 through `symphonia`, as mono f64 in full-scale units at
//! the file's own sample rate. Rejects inputs that would give meaningless fits with a one-line
//! reason naming the file.
//!
//! Integer samples of `bits` bits become `v / 2^(bits−1)` whichever decoder reads them (hound's
//! `v · 2^−(bits−1)`, symphonia's division of the MSB-aligned sample by `2^15` or `2^31`: exact in
//! f64 either way), and channels are mixed by one function, so a WAV, its FLAC and its AIFF give
//! bit-identical recordings (`tests/integration/fit_formats.rs`).

use std::io::Read;
use std::path::Path;
use symphonia::core::codecs::audio::AudioDecoderOptions;
use symphonia::core::errors::Error as DecodeError;
use symphonia::core::formats::probe::Hint;
use symphonia::core::formats::TrackType;
use symphonia::core::io::MediaSourceStream;

/// Lowest sample rate accepted (Hz): below it the modes above ~10 kHz that carry metal and glass
/// timbre are lost (the recordings used here go down to 20 kHz).
pub const MIN_RATE_HZ: u32 = 20_000;
/// Highest sample rate accepted (Hz): above 192 kHz the fit only costs time (nothing audible).
pub const MAX_RATE_HZ: u32 = 192_000;
/// The formats read, in words (help texts, errors).
pub const FORMATS: &str = "WAV, FLAC, AIFF, Ogg Vorbis or MP3";
/// File extensions (lower case) of recordings: what a folder contributes and file dialogs offer.
pub const EXTENSIONS: [&str; 9] = ["wav", "wave", "flac", "aif", "aiff", "aifc", "ogg", "oga", "mp3"];

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

/// A container of recordings this module reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Container {
    /// RIFF/RF64 WAVE (read by `hound`).
    Wav,
    /// Native FLAC.
    Flac,
    /// AIFF or AIFF-C.
    Aiff,
    /// Ogg (Vorbis; Ogg FLAC too).
    Ogg,
    /// MPEG audio layer III.
    Mp3,
}

impl Container {
    /// Its name in errors.
    pub fn name(self) -> &'static str {
        match self {
            Container::Wav => "WAV",
            Container::Flac => "FLAC",
            Container::Aiff => "AIFF",
            Container::Ogg => "Ogg",
            Container::Mp3 => "MP3",
        }
    }

    /// The container whose header `head` (a file's first 12 bytes or more) starts with. An ID3v2
    /// tag is taken for MP3 (which [`Container::of_file`] refines by the extension: a FLAC may
    /// start with one too).
    pub fn sniff(head: &[u8]) -> Option<Container> {
        let at = |i: usize, tag: &[u8]| head.get(i..i + tag.len()) == Some(tag);
        if (at(0, b"RIFF") || at(0, b"RF64")) && at(8, b"WAVE") {
            Some(Container::Wav)
        } else if at(0, b"FORM") && (at(8, b"AIFF") || at(8, b"AIFC")) {
            Some(Container::Aiff)
        } else if at(0, b"fLaC") {
            Some(Container::Flac)
        } else if at(0, b"OggS") {
            Some(Container::Ogg)
        } else if at(0, b"ID3") || (head.len() >= 2 && head[0] == 0xFF && head[1] & 0xE6 == 0xE2) {
            // An MPEG audio frame sync (11 bits) with layer III (`01` in bits 2–1).
            Some(Container::Mp3)
        } else {
            None
        }
    }

    /// The container of the file at `path` by its header, else by its extension; `None` for a
    /// file that is neither (or cannot be opened).
    pub fn of_file(path: &Path) -> Option<Container> {
        let mut head = Vec::with_capacity(12);
        let sniffed = std::fs::File::open(path)
            .and_then(|f| f.take(12).read_to_end(&mut head))
            .ok()
            .and_then(|_| Container::sniff(&head));
        let by_name = Container::of_extension(path);
        match sniffed {
            Some(Container::Mp3) if head.starts_with(b"ID3") => {
                by_name.filter(|c| *c != Container::Wav).or(sniffed)
            }
            Some(c) => Some(c),
            None => by_name,
        }
    }

    /// The container a file's extension names.
    pub fn of_extension(path: &Path) -> Option<Container> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "wav" | "wave" => Container::Wav,
            "flac" => Container::Flac,
            "aif" | "aiff" | "aifc" => Container::Aiff,
            "ogg" | "oga" => Container::Ogg,
            "mp3" => Container::Mp3,
            _ => return None,
        })
    }
}

/// Whether `path` is named as a recording ([`EXTENSIONS`], any case).
pub fn has_recording_extension(path: &Path) -> bool {
    Container::of_extension(path).is_some()
}

/// Interleaved samples as decoded, before mixing.
struct Decoded {
    interleaved: Vec<f64>,
    channels: usize,
    rate: u32,
}

/// Reads a recording in any of the [`FORMATS`]; errors are one line and name the file.
pub fn read_recording(path: &Path) -> anyhow::Result<Recording> {
    let name = path.display();
    let container = match Container::of_file(path) {
        Some(c) => c,
        None if !path.exists() => anyhow::bail!("{name}: no such file"),
        None => anyhow::bail!("{name}: not a recording ({FORMATS} header or name expected)"),
    };
    let d = match container {
        Container::Wav => read_wav(path)?,
        other => read_symphonia(path, other)?,
    };
    let ch = d.channels.max(1);
    let samples: Vec<f64> = d
        .interleaved
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
        sample_rate: f64::from(d.rate),
        note,
    };
    check_signal(&rec.samples, rec.sample_rate).map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    Ok(rec)
}

/// The sample-rate bounds, checked before decoding.
fn check_rate(name: &std::path::Display<'_>, rate: u32) -> anyhow::Result<()> {
    if !(MIN_RATE_HZ..=MAX_RATE_HZ).contains(&rate) {
        anyhow::bail!(
            "{name}: sample rate {rate} Hz is outside the supported {MIN_RATE_HZ}..={MAX_RATE_HZ} Hz"
        );
    }
    Ok(())
}

/// The 8-bit refusal, for WAV and for the lossless codecs alike.
fn check_bits(name: &std::path::Display<'_>, kind: &str, bits: u32) -> anyhow::Result<()> {
    if bits <= 8 {
        anyhow::bail!(
            "{name}: 8-bit {kind} is not supported (48 dB of dynamic range is too little to fit decays); convert to 16-bit or more"
        );
    }
    Ok(())
}

/// A WAV file through `hound`: PCM of 9 to 32 bits or 32-bit float.
fn read_wav(path: &Path) -> anyhow::Result<Decoded> {
    let name = path.display();
    let reader =
        hound::WavReader::open(path).map_err(|e| anyhow::anyhow!("{name}: not a readable WAV file ({e})"))?;
    let spec = reader.spec();
    if spec.sample_format == hound::SampleFormat::Int {
        check_bits(&name, "WAV", u32::from(spec.bits_per_sample))?;
    }
    check_rate(&name, spec.sample_rate)?;
    // PCM holds no checksum, so a sample that cannot be read is one past the end of the file.
    let stated = reader.len();
    let truncated = |e: hound::Error, read: usize| {
        anyhow::anyhow!(
            "{name}: truncated WAV stream ({read} of the {stated} samples its header states; {e})"
        )
    };
    let mut interleaved: Vec<f64> = Vec::with_capacity(stated as usize);
    match spec.sample_format {
        hound::SampleFormat::Float => {
            for s in reader.into_samples::<f32>() {
                interleaved.push(f64::from(s.map_err(|e| truncated(e, interleaved.len()))?));
            }
        }
        hound::SampleFormat::Int => {
            let scale = 1.0 / f64::from(1u32 << (spec.bits_per_sample - 1));
            for s in reader.into_samples::<i32>() {
                interleaved.push(f64::from(s.map_err(|e| truncated(e, interleaved.len()))?) * scale);
            }
        }
    }
    Ok(Decoded {
        interleaved,
        channels: usize::from(spec.channels),
        rate: spec.sample_rate,
    })
}

/// FLAC, AIFF, Ogg Vorbis or MP3 through `symphonia`. A stream is refused, not partly read, when
/// a packet is malformed, when it ends before the length its header states (FLAC's STREAMINFO,
/// AIFF's COMM chunk, an MP3's Xing/Info frame, Ogg's last granule position) or when FLAC's MD5 of
/// the decoded audio does not match: a fit of a damaged file would fit the damage.
fn read_symphonia(path: &Path, kind: Container) -> anyhow::Result<Decoded> {
    let name = path.display();
    let k = kind.name();
    let file = std::fs::File::open(path).map_err(|e| anyhow::anyhow!("{name}: cannot open ({e})"))?;
    let mss = MediaSourceStream::new(Box::new(file), Default::default());
    let mut hint = Hint::new();
    if let Some(ext) = path.extension().and_then(|e| e.to_str()) {
        hint.with_extension(ext);
    }
    let mut format = symphonia::default::get_probe()
        .probe(&hint, mss, Default::default(), Default::default())
        .map_err(|e| match e {
            DecodeError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                anyhow::anyhow!("{name}: truncated {k} file (it ends inside the structure its headers state)")
            }
            e => anyhow::anyhow!("{name}: not a readable {k} file ({})", reason(&e)),
        })?;
    let track = format
        .default_track(TrackType::Audio)
        .ok_or_else(|| anyhow::anyhow!("{name}: no audio track in the {k} file"))?;
    let (track_id, expected_frames) = (track.id, track.num_frames);
    let params = track
        .codec_params
        .as_ref()
        .and_then(|p| p.audio())
        .ok_or_else(|| anyhow::anyhow!("{name}: the {k} file's audio track has no codec parameters"))?
        .clone();
    let codecs = symphonia::default::get_codecs();
    let Some(codec) = codecs.get_audio_decoder(params.codec) else {
        anyhow::bail!(
            "{name}: unsupported codec in the {k} file (codec id {}); Tactus decodes PCM, FLAC, Vorbis and MP3 audio",
            params.codec
        );
    };
    let codec_name = codec.codec.info.short_name;
    let mut decoder = codecs
        .make_audio_decoder(&params, &AudioDecoderOptions::default().verify(true))
        .map_err(|e| anyhow::anyhow!("{name}: unsupported {codec_name} stream ({})", reason(&e)))?;
    if let Some(rate) = params.sample_rate {
        check_rate(&name, rate)?;
    }
    if let Some(bits) = params
        .bits_per_sample
        .filter(|_| params.sample_format.is_none_or(is_integer))
    {
        check_bits(&name, codec_name, bits)?;
    }
    let mut interleaved = Vec::new();
    let mut packet_samples: Vec<f64> = Vec::new();
    let mut layout: Option<(usize, u32)> = None;
    let mut frames = 0u64;
    let damaged = |e: DecodeError, frames: u64| match e {
        DecodeError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            anyhow::anyhow!("{name}: truncated {k} stream (ends inside a packet after {frames} frames)")
        }
        DecodeError::ResetRequired => anyhow::anyhow!(
            "{name}: the {k} file chains streams with different parameters; export it as one stream"
        ),
        e => anyhow::anyhow!("{name}: corrupt {k} data after {frames} frames ({})", reason(&e)),
    };
    loop {
        let packet = match format.next_packet() {
            Ok(Some(p)) => p,
            Ok(None) => break,
            Err(e) => return Err(damaged(e, frames)),
        };
        if packet.track_id != track_id {
            continue;
        }
        let audio = decoder.decode(&packet).map_err(|e| damaged(e, frames))?;
        let this = (audio.spec().channels().count(), audio.spec().rate());
        match layout {
            None => {
                check_rate(&name, this.1)?;
                layout = Some(this);
            }
            Some(first) if first != this => anyhow::bail!(
                "{name}: the {k} stream changes from {} channels at {} Hz to {} at {} Hz; export it as one stream",
                first.0,
                first.1,
                this.0,
                this.1
            ),
            Some(_) => {}
        }
        audio.copy_to_vec_interleaved(&mut packet_samples);
        interleaved.extend_from_slice(&packet_samples);
        frames += audio.frames() as u64;
    }
    // Frames missing at the end or lost in the middle (a reader resynchronises past a damaged
    // frame): truncated or damaged, the count cannot tell which.
    if let Some(n) = expected_frames.filter(|&n| frames < n) {
        anyhow::bail!(
            "{name}: truncated or damaged {k} stream ({frames} of the {n} frames its header states were decoded)"
        );
    }
    if decoder.finalize().verify_ok == Some(false) {
        anyhow::bail!("{name}: corrupt {k} data (the decoded audio fails the stream's MD5 checksum)");
    }
    let Some((channels, rate)) = layout else {
        anyhow::bail!("{name}: the {k} file holds no audio");
    };
    Ok(Decoded {
        interleaved,
        channels,
        rate,
    })
}

/// Whether samples of `f` are integers (the 8-bit refusal applies to them only).
fn is_integer(f: symphonia::core::audio::sample::SampleFormat) -> bool {
    use symphonia::core::audio::sample::SampleFormat as F;
    !matches!(f, F::F32 | F::F64)
}

/// A decoding error's reason without symphonia's prefixes' redundancy.
fn reason(e: &DecodeError) -> String {
    match e {
        DecodeError::Unsupported(what) => format!("unsupported: {what}"),
        DecodeError::DecodeError(what) => format!("malformed: {what}"),
        e => e.to_string(),
    }
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
