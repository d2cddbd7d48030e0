"""Stereo pickups of Tactus.vst3 in pedalboard (docs/model.md "Stereo pickups").

A rendered note is stereo at the default width (inter-channel correlation in 0.3–0.97), mono at
width 0 (identical channels), and at any width L+R keeps the width-0 energy per octave band
within 3 dB (the width moves energy between the channels, not out of their sum).
"""

import numpy as np
import pedalboard
import pytest

from conftest import SAMPLE_RATE, find_param, render

# The default the plugin declares (src/engine/stereo.rs, DEFAULT_WIDTH).
DEFAULT_WIDTH = 0.5


@pytest.fixture()
def plugin(vst3_path):
    return pedalboard.load_plugin(str(vst3_path))


def note() -> list[tuple[bytes, float]]:
    return [(bytes([0x90, 60, 100]), 0.0), (bytes([0x80, 60, 0]), 0.5)]


def set_width(plugin, width: float) -> None:
    attr, _ = find_param(plugin, "Width")
    setattr(plugin, attr, width)
    assert abs(getattr(plugin, attr) - width) < 1e-3


def correlation(left: np.ndarray, right: np.ndarray) -> float:
    left = left.astype(np.float64)
    right = right.astype(np.float64)
    return float(np.sum(left * right) / np.sqrt(np.sum(left * left) * np.sum(right * right)))


def octave_energies(x: np.ndarray) -> np.ndarray:
    """Energy per octave band, centres 31.25 Hz … 16 kHz, edges centre·2^±½."""
    spec = np.abs(np.fft.rfft(x.astype(np.float64))) ** 2
    freqs = np.fft.rfftfreq(len(x), 1.0 / SAMPLE_RATE)
    centres = 31.25 * 2.0 ** np.arange(10)
    return np.array(
        [spec[(freqs >= c / np.sqrt(2)) & (freqs < c * np.sqrt(2))].sum() for c in centres]
    )


def test_default_width_is_stereo_and_width_zero_is_mono(plugin):
    attr, param = find_param(plugin, "Width")
    assert abs(getattr(plugin, attr) - DEFAULT_WIDTH) < 1e-3, param.string_value
    wide = render(plugin, note())
    assert wide.shape == (2, 2 * SAMPLE_RATE)
    assert np.all(np.isfinite(wide)) and np.max(np.abs(wide)) > 1e-4
    c = correlation(wide[0], wide[1])
    print(f"default width {DEFAULT_WIDTH}: inter-channel correlation {c:.3f}")
    assert 0.3 <= c <= 0.97, c

    set_width(plugin, 0.0)
    mono = render(plugin, note())
    assert np.array_equal(mono[0], mono[1]), "channels differ at width 0"

    # L+R per octave band: the default width against width 0 (bands 100 dB under the loudest
    # hold rounding only).
    e0 = octave_energies(mono[0] + mono[1])
    e1 = octave_energies(wide[0] + wide[1])
    keep = e0 > 1e-10 * e0.max()
    diff = np.abs(10.0 * np.log10(e1[keep] / e0[keep]))
    print("L+R per octave band, default width vs 0 (dB):", np.round(diff, 4))
    assert diff.max() < 3.0, diff

    set_width(plugin, 1.0)
    full = render(plugin, note())
    c1 = correlation(full[0], full[1])
    print(f"width 1: inter-channel correlation {c1:.3f}")
    assert c1 < c
