"""The output limiter (the Limiter parameter, docs/plugin.md "Output limiter") in a real host,
DawDreamer: the loudest setup a user can make — every numeric control at its maximum (Gain,
Velocity, Hardness, Mass, Height, Restitution, Fragments, the scrape and roll speeds and
pressures, Quality, ...), the largest valid user preset (`preset::worst_case_preset`, written by
`tactus preset worst-case`), 64 notes at full velocity at once, then Break, Bounce and Rattle
notes while scraping and rolling — leaves no sample above the ceiling (−0.3 dBFS); with the
limiter off the unlimited peak, tens of dB over full scale, returns; quiet material renders
bit-identical with it on and off."""

import os
import tempfile
from pathlib import Path

import dawdreamer as daw
import numpy as np

from conftest import BUFFER_SIZE, PARAMS, SAMPLE_RATE
from rt_child import worst_case_preset

# src/engine/limiter.rs CEILING: 10^(−0.3/20) as the nearest float32.
CEILING = np.float32(10 ** (-0.3 / 20))
DURATION = 2.0
# Gesture choices in parameter order (Strike, Bounce, Break, Rattle), normalised.
GESTURE = {"Strike": 0.0, "Bounce": 1 / 3, "Break": 2 / 3, "Rattle": 1.0}
# Which gesture each note group plays, and when (s): the Gesture lane switches just before.
PHASES = [("Strike", 0.05, 64), ("Break", 0.55, 16), ("Bounce", 1.05, 16), ("Rattle", 1.55, 16)]
# Not numeric controls: which object, what the keys and notes do, the limiter itself.
NOT_MAXED = {"Material", "Seed", "New Object", "Note Mode", "Gesture", "Contact Model", "Scrape Motion", "Limiter"}


def param_index(synth, name: str) -> int:
    for i in range(synth.get_plugin_parameter_size()):
        if synth.get_parameter_name(i) == name:
            return i
    raise KeyError(name)


def user_preset_norm(synth, index: int) -> float:
    """The normalised Material value whose text is "User Preset" (measured, not assumed)."""
    for x in np.linspace(0.0, 1.0, 1001):
        synth.set_parameter(index, float(x))
        if synth.get_parameter_text(index) == "User Preset":
            return float(x)
    raise AssertionError("no User Preset entry in Material")


def loudest_render(vst3_path, limiter: bool) -> np.ndarray:
    engine = daw.RenderEngine(SAMPLE_RATE, BUFFER_SIZE)
    with tempfile.TemporaryDirectory() as tmp:
        worst = Path(tmp) / "worst.json"
        worst_case_preset("plain", worst)
        os.environ["TACTUS_USER_PRESET"] = str(worst)
        try:
            synth = engine.make_plugin_processor("tactus", str(vst3_path))
        finally:
            del os.environ["TACTUS_USER_PRESET"]
    material = param_index(synth, "Material")
    synth.set_parameter(material, user_preset_norm(synth, material))
    maxed = [name for name in PARAMS.values() if name not in NOT_MAXED]
    for name in maxed:
        synth.set_parameter(param_index(synth, name), 1.0)
    synth.set_parameter(param_index(synth, "Limiter"), 1.0 if limiter else 0.0)
    n = int(DURATION * SAMPLE_RATE)
    t = np.arange(n) / SAMPLE_RATE
    lane = np.zeros(n, dtype=np.float32)
    for gesture, start, _ in PHASES:
        lane[t >= start - 0.02] = GESTURE[gesture]
    assert synth.set_automation(param_index(synth, "Gesture"), lane)
    for _, start, notes in PHASES:
        for k in range(notes):
            synth.add_midi_note(30 + k, 127, start, 0.3)
    engine.load_graph([(synth, [])])
    engine.render(DURATION)
    audio = np.asarray(synth.get_audio())
    assert audio.shape[0] == 2 and audio.shape[1] >= n - BUFFER_SIZE
    assert np.all(np.isfinite(audio)), "non-finite output"
    return audio


def test_the_loudest_setup_never_passes_the_ceiling(vst3_path):
    limited = loudest_render(vst3_path, limiter=True)
    unlimited = loudest_render(vst3_path, limiter=False)
    p_on, p_off = np.max(np.abs(limited)), np.max(np.abs(unlimited))
    print(
        f"\nloudest setup: peak {p_off:.4g} ({20 * np.log10(p_off):+.1f} dBFS) unlimited, "
        f"{p_on:.7f} ({20 * np.log10(p_on):+.2f} dBFS) limited; ceiling {CEILING:.7f}"
    )
    assert p_on <= CEILING, f"a sample above the ceiling: {p_on}"
    # Limited, not muted: within 1 dB of the ceiling.
    assert p_on > CEILING * 10 ** (-1 / 20), p_on
    # Off, the unlimited output returns: over +40 dBFS.
    assert p_off > 100.0, p_off


def quiet_render(vst3_path, limiter: bool) -> np.ndarray:
    engine = daw.RenderEngine(SAMPLE_RATE, BUFFER_SIZE)
    synth = engine.make_plugin_processor("tactus", str(vst3_path))
    gain = param_index(synth, "Gain")
    synth.set_parameter(gain, (-24.0 + 60.0) / 72.0)  # −24 dB on the −60..12 dB range
    synth.set_parameter(param_index(synth, "Limiter"), 1.0 if limiter else 0.0)
    for i in range(6):
        synth.add_midi_note(48 + 5 * i, 100, 0.05 + 0.3 * i, 0.1)
    engine.load_graph([(synth, [])])
    engine.render(DURATION)
    return np.asarray(synth.get_audio())


def test_quiet_material_passes_bit_identical(vst3_path):
    on, off = quiet_render(vst3_path, True), quiet_render(vst3_path, False)
    peak = np.max(np.abs(on))
    print(f"\nquiet render: peak {20 * np.log10(peak + 1e-30):.1f} dBFS")
    assert 0 < peak <= CEILING / 2, "the test needs material 6 dB under the ceiling"
    assert np.array_equal(on, off), "the limiter changed quiet material"
