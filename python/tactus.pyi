"""Tactus: physically based contact sounds (impacts, scraping, rolling) from a modal resonator
bank. See docs/python.md."""

import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

#: The embedded demo scene (what `tactus render --demo` renders), as JSON text.
DEMO_SCENE: str

_Path = Union[str, "os.PathLike[str]"]
_Json = Union[Mapping[str, Any], str, _Path]

def render(
    scene: _Json,
    stems: bool = False,
    *,
    block: int = 256,
    limit: bool = False,
) -> Union[
    Tuple[npt.NDArray[np.float32], int],
    Tuple[npt.NDArray[np.float32], int, Dict[str, npt.NDArray[np.float32]]],
]:
    """Render a scene (dict, JSON string or path) as `tactus render` does.

    Returns `(audio, sample_rate)`, `audio` float32 of shape (frames, 2), sample for sample
    what `tactus render --format float32` writes; with `stems=True`
    `(audio, sample_rate, stems)`, `stems` a dict object name -> (frames, 2) array (a
    one-object scene's object is "object"). `block` is the processing block size, 1..=8192.
    `limit=True` passes the mix (not the stems) through the plugin's output limiter (no
    sample above -0.3 dBFS; the CLI's `--limit`); by default the render is unlimited.

    Raises ValueError for an invalid scene, OSError for an unreadable scene file,
    KeyboardInterrupt on Ctrl-C.
    """

def batch(
    spec: _Json,
    out_dir: _Path,
    threads: Optional[int] = None,
    shard: Union[str, Tuple[int, int], None] = None,
    *,
    format: str = "pcm24",
    wav_header: str = "plain",
    block: int = 256,
    limit: bool = False,
) -> Dict[str, Any]:
    """Render variations of a scene into `out_dir` with a manifest, as `tactus batch` does.

    `spec` is a variation spec (dict, JSON string or path; docs/batch.md) or the path of a
    JSON-lines file of scenes (`.jsonl`). `shard` is "I/N" or (I, N). `format` is "pcm16",
    "pcm24" or "float32"; `wav_header` "plain" or "extensible"; `limit=True` passes each
    render through the plugin's output limiter (the CLI's `--limit`).

    Returns {"rendered": int, "skipped": int, "manifest": path of the manifest .jsonl}.
    Raises ValueError for an invalid spec or scene, OSError for files, KeyboardInterrupt on
    Ctrl-C (finished files stay; a rerun resumes).
    """

def fit(
    paths: Union[_Path, Sequence[_Path]],
    material: str,
    name: Optional[str] = None,
    out: Optional[_Path] = None,
    *,
    modes: int = 24,
    family_by: str = "auto",
    strict: bool = False,
) -> Dict[str, Any]:
    """Fit a material preset from recordings (WAV, FLAC, AIFF, Ogg Vorbis or MP3 files, or
    folders of them), or from measured mode tables (`.json` as PyImpact's, `.csv` lines
    `object,frequency_hz,level_db,t60_s`; not mixed with recordings), as `tactus fit` does.

    Returns the preset as a dict; writes it to `out` when given. Recordings that cannot be
    fitted are left out with a UserWarning (an error with `strict=True`). `family_by` is
    "auto", "manifest", "name", "folder" or "none".

    Raises ValueError when nothing can be fitted or an argument is invalid, OSError for a
    missing input or unwritable `out`, KeyboardInterrupt on Ctrl-C.
    """

def materials() -> List[str]:
    """Names of the built-in materials (a scene's `material`, case-insensitive)."""

def surfaces() -> List[str]:
    """Names a scrape or roll event's `surface` accepts: "synthetic", then the measured ones."""

def features(audio: npt.ArrayLike, sample_rate: float) -> Dict[str, float]:
    """The features `tactus eval` measures: centroid_hz, tan_phi, t60_s, decay_slope,
    attack_share, edt_s, peak_count.

    `audio` is 1-D (mono) or (frames, channels), mixed to mono by the channel mean as
    `tactus eval` mixes recordings and renders. Raises ValueError for a signal without these
    features (the reason in words).
    """
