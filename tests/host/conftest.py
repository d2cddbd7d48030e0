"""Shared fixtures for the real-host tests of Tactus.vst3.

The bundle path comes from the environment variable ``TACTUS_VST3`` (default
``target/bundled/Tactus.vst3`` relative to the repository root). Build it first with
``cargo xtask bundle tactus --release``.
"""

import os
import re
from pathlib import Path

import numpy as np
import pedalboard
import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
SAMPLE_RATE = 48000
BUFFER_SIZE = 512

# Parameter ids (stable) → display names, as declared in src/plugin/params.rs.
PARAMS = {
    "material": "Material",
    "size": "Size",
    "damping": "Damping",
    "mass": "Mass",
    "velocity": "Velocity",
    "hardness": "Hardness",
    "contact_model": "Contact Model",
    "scrape_speed": "Scrape Speed",
    "scrape_motion": "Scrape Motion",
    "scrape_pressure": "Scrape Pressure",
    "roughness": "Roughness",
    "roll_speed": "Roll Speed",
    "roll_radius": "Roll Radius",
    "roll_eccentricity": "Roll Eccentricity",
    "variation": "Variation",
    "quality": "Quality",
    "gain": "Gain",
    "new_object": "New Object",
    "seed": "Seed",
    "note_mode": "Note Mode",
    "roll_pressure": "Roll Pressure",
    "width": "Width",
    "gesture": "Gesture",
    "height": "Height",
    "restitution": "Restitution",
    "fragments": "Fragments",
    "rattle_rate": "Rattle Rate",
    "spread": "Spread",
    "surface": "Surface",
    "limiter": "Limiter",
}


# MidiConfig::MidiCCs makes nice-plug's VST3 wrapper expose MIDI controllers as hidden proxy
# parameters ("MIDI Ch. 3 CC 1", "MIDI Ch. 3 Channel Pressure"): that is how VST3 delivers them.
# Tactus lists only CC 1 and channel pressure (32 proxies, docs/plugin.md "MIDI"). They are not
# plugin parameters: pedalboard already skips JUCE's own proxies ("MIDI CC ..."); add
# nice-plug's names to the same list so `plugin.parameters` holds exactly Tactus's parameters.
# The proxies stay reachable through the native `plugin._parameters` list (test_rt_safety
# randomises them all); test_load_time.py measures a load without this skip, as a user gets it.
MIDI_PROXY_NAME = re.compile(r"MIDI Ch\. \d+ (CC \d+|Channel Pressure|Pitch Bend)$")


def skip_midi_proxies_in_pedalboard() -> None:
    ignore = getattr(pedalboard._pedalboard, "PARAMETER_NAME_REGEXES_TO_IGNORE", None)
    if ignore is not None:  # pedalboard 0.9.x; otherwise only slower
        ignore.add(MIDI_PROXY_NAME)


skip_midi_proxies_in_pedalboard()


def bundle_from_env(var: str, default: str | None) -> Path | None:
    value = os.environ.get(var) or default
    if value is None:
        return None
    path = Path(value)
    if not path.is_absolute():
        path = REPO_ROOT / path
    return path


def require_bundle(path: Path, var: str) -> Path:
    so_dir = path / "Contents" / "x86_64-linux"
    if not path.is_dir() or not any(so_dir.glob("*.so")):
        pytest.fail(
            f"Tactus VST3 bundle not found at {path} (no {so_dir}/*.so). Build it with "
            f"`cargo xtask bundle tactus --release` or point {var} at a Tactus.vst3 bundle.",
            pytrace=False,
        )
    return path


@pytest.fixture(scope="session")
def vst3_path() -> Path:
    path = bundle_from_env("TACTUS_VST3", "target/bundled/Tactus.vst3")
    if "TACTUS_VST3" not in os.environ and not path.exists():
        # nice-plug-xtask names the bundle after the package unless bundler.toml says otherwise.
        path = REPO_ROOT / "target/bundled/tactus.vst3"
    return require_bundle(path, "TACTUS_VST3")


def note_ons(
    velocity: int, times=(0.0, 0.5, 1.0, 1.5), key: int = 60
) -> list[tuple[bytes, float]]:
    """Note-on (and matching note-off) messages for pedalboard."""
    msgs = []
    for t in times:
        msgs.append((bytes([0x90, key, velocity]), t))
        msgs.append((bytes([0x80, key, 0]), t + 0.25))
    return msgs


def render(plugin, messages, duration: float = 2.0) -> np.ndarray:
    out = plugin(
        messages,
        duration=duration,
        sample_rate=SAMPLE_RATE,
        num_channels=2,
        buffer_size=BUFFER_SIZE,
        reset=True,
    )
    return np.asarray(out)


def rms_db(x: np.ndarray) -> float:
    return 20.0 * np.log10(np.sqrt(np.mean(np.square(x, dtype=np.float64))) + 1e-30)


def peak_db(x: np.ndarray) -> float:
    return 20.0 * np.log10(np.max(np.abs(x)) + 1e-30)


def find_param(plugin, display_name: str):
    """Returns (pedalboard attribute name, parameter) for a display name."""
    for attr, param in plugin.parameters.items():
        if param.name == display_name:
            return attr, param
    raise KeyError(display_name)
