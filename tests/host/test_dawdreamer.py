"""Tactus.vst3 in DawDreamer (JUCE-based offline renderer): notes plus a parameter automation lane."""

import dawdreamer as daw
import numpy as np

from conftest import BUFFER_SIZE, SAMPLE_RATE

DURATION = 2.0
NOTE_TIMES = [0.05 + 0.25 * i for i in range(8)]
GAIN_MIN_DB, GAIN_MAX_DB = -60.0, 12.0


def gain_norm(db: float) -> float:
    return (db - GAIN_MIN_DB) / (GAIN_MAX_DB - GAIN_MIN_DB)


def param_index(synth, name: str) -> int:
    for i in range(synth.get_plugin_parameter_size()):
        if synth.get_parameter_name(i) == name:
            return i
    raise KeyError(name)


def render(vst3_path, automation=None, constant=None) -> np.ndarray:
    engine = daw.RenderEngine(SAMPLE_RATE, BUFFER_SIZE)
    synth = engine.make_plugin_processor("tactus", str(vst3_path))
    assert synth.get_num_output_channels() == 2
    gain = param_index(synth, "Gain")
    for t in NOTE_TIMES:
        synth.add_midi_note(60, 100, t, 0.1)
    if constant is not None:
        synth.set_parameter(gain, constant)
    if automation is not None:
        assert synth.set_automation(gain, automation)
    engine.load_graph([(synth, [])])
    engine.render(DURATION)
    audio = np.asarray(synth.get_audio())
    assert audio.shape[0] == 2 and audio.shape[1] >= int(DURATION * SAMPLE_RATE) - BUFFER_SIZE
    assert np.all(np.isfinite(audio))
    return audio


def note_peaks_db(audio: np.ndarray) -> np.ndarray:
    """Peak level (dB) in the first 100 ms after each note onset."""
    mono = np.max(np.abs(audio), axis=0)
    peaks = []
    for t in NOTE_TIMES:
        s = int(t * SAMPLE_RATE)
        peaks.append(np.max(mono[s : s + SAMPLE_RATE // 10]))
    return 20 * np.log10(np.array(peaks) + 1e-30)


def test_gain_automation_lane_shapes_envelope(vst3_path):
    n = int(DURATION * SAMPLE_RATE)
    t = np.arange(n) / SAMPLE_RATE
    ramp_db = -40.0 + 40.0 * t / DURATION  # -40 dB → 0 dB over the render
    lane = np.array([gain_norm(x) for x in ramp_db], dtype=np.float32)

    flat = render(vst3_path, constant=gain_norm(0.0))
    ramped = render(vst3_path, automation=lane)

    flat_db = note_peaks_db(flat)
    ramp_peaks = note_peaks_db(ramped)
    assert np.min(flat_db) > -60.0, "flat render is silent"
    # Same notes at constant gain: similar level per note (variation is ±20 % mode power).
    assert np.ptp(flat_db) < 6.0, flat_db
    diff = ramp_peaks - flat_db
    expected = np.interp(NOTE_TIMES, t, ramp_db)
    print("note times      ", NOTE_TIMES)
    print("flat peaks dB   ", np.round(flat_db, 2))
    print("ramped peaks dB ", np.round(ramp_peaks, 2))
    print("ramped - flat   ", np.round(diff, 2))
    print("automation value", np.round(expected, 2))
    # The envelope follows the lane: monotonic rise, and each note within 3 dB of the
    # automation value at its onset (gain is sampled per block, 512 samples ≈ 10.7 ms).
    assert np.all(np.diff(diff) > 0), diff
    assert diff[-1] - diff[0] > 25.0, diff
    assert np.max(np.abs(diff - expected)) < 3.0, diff - expected
