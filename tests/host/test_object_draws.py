"""A change that draws a new object (Material, Seed, New Object) before a note: the note plays
the new object in the render that brings the change, in DawDreamer and in pedalboard, whatever
process mode the host reports and however fast it renders (docs/plugin.md, "Where objects are
drawn"). Two renders of the same project are identical sample for sample."""

import dawdreamer as daw
import numpy as np
import pedalboard
import pytest

from conftest import BUFFER_SIZE, SAMPLE_RATE, find_param

DURATION = 1.0
NOTE_S = 0.1
AUTOMATED_NOTE_S = 0.3
SEED_MAX = 999_999
SEED = 777
# Normalised values: Material is an integer 0..17 (0 = Wood; the default is 1, Metal), Seed
# 0..999999, New Object a switch.
CHANGES = {
    "Material": 0.0,
    "Seed": SEED / SEED_MAX,
    "New Object": 1.0,
}


def param_index(synth, name: str) -> int:
    for i in range(synth.get_plugin_parameter_size()):
        if synth.get_parameter_name(i) == name:
            return i
    raise KeyError(name)


class DawProject:
    """One DawDreamer engine with Tactus, a note, and optionally a change of one parameter."""

    def __init__(self, vst3_path, note_s: float):
        self.engine = daw.RenderEngine(SAMPLE_RATE, BUFFER_SIZE)
        self.synth = self.engine.make_plugin_processor("tactus", str(vst3_path))
        self.synth.add_midi_note(60, 100, note_s, 0.1)
        self.engine.load_graph([(self.synth, [])])

    def set(self, name: str, value: float) -> None:
        self.synth.set_parameter(param_index(self.synth, name), value)

    def automate(self, name: str, value: float) -> None:
        lane = np.full(int(DURATION * SAMPLE_RATE), value, dtype=np.float32)
        assert self.synth.set_automation(param_index(self.synth, name), lane)

    def render(self) -> np.ndarray:
        self.engine.render(DURATION)
        audio = np.asarray(self.synth.get_audio())
        assert np.all(np.isfinite(audio))
        return audio


def daw_default(vst3_path, note_s: float) -> np.ndarray:
    audio = DawProject(vst3_path, note_s).render()
    assert np.max(np.abs(audio)) > 1e-4, "the note is silent"
    return audio


@pytest.mark.parametrize("name", CHANGES)
@pytest.mark.parametrize("how", ["set_parameter", "automation"])
def test_dawdreamer_note_plays_the_object_of_a_change_before_it(vst3_path, name, how):
    note_s = NOTE_S if how == "set_parameter" else AUTOMATED_NOTE_S
    project = DawProject(vst3_path, note_s)
    if how == "set_parameter":
        project.set(name, CHANGES[name])
    else:
        # The lane holds the new value over the whole render, as a DAW's automation would.
        project.automate(name, CHANGES[name])
    first = project.render()
    # The second render starts with the new object already in place (the change was applied
    # in the first; a held New Object does not trigger again): the reference.
    second = project.render()
    default = daw_default(vst3_path, note_s)
    assert not np.array_equal(second, default), f"{name}: the change is not audible"
    diff = np.max(np.abs(first - second))
    assert np.array_equal(first, second), (
        f"{name} by {how}: the note in the render that brings the change differs from one "
        f"that starts with the new object by up to {diff} (it played the old object)"
    )


@pytest.mark.parametrize("how", ["set_parameter", "automation"])
def test_dawdreamer_renders_of_one_project_are_identical(vst3_path, how):
    renders = []
    for _ in range(2):
        project = DawProject(vst3_path, AUTOMATED_NOTE_S)
        for name, value in CHANGES.items():
            if how == "set_parameter":
                project.set(name, value)
            else:
                project.automate(name, value)
        renders.append(project.render())
    assert np.max(np.abs(renders[0])) > 1e-4
    assert np.array_equal(renders[0], renders[1]), (
        f"two renders differ by up to {np.max(np.abs(renders[0] - renders[1]))}"
    )


def pb_render(plugin, notes, reset: bool, duration: float = DURATION) -> np.ndarray:
    msgs = []
    for t in notes:
        msgs += [(bytes([0x90, 60, 100]), t), (bytes([0x80, 60, 0]), t + 0.1)]
    out = plugin(
        msgs,
        duration=duration,
        sample_rate=SAMPLE_RATE,
        num_channels=2,
        buffer_size=BUFFER_SIZE,
        reset=reset,
    )
    out = np.asarray(out)
    assert np.all(np.isfinite(out))
    return out


def pb_set(plugin, name: str, normalised: float) -> None:
    attr, _ = find_param(plugin, name)
    plugin.parameters[attr].raw_value = normalised


def pb_stream(vst3_path, change: str | None, before_lead_in: bool) -> np.ndarray:
    """A silent 0.5 s lead-in, then (`reset=False`: the plugin keeps processing, no
    re-activation, so a change made here reaches `process`, not `activate`) a chunk with a note.
    `change` is set before the lead-in or between the chunks."""
    plugin = pedalboard.load_plugin(str(vst3_path))
    if change and before_lead_in:
        pb_set(plugin, change, CHANGES[change])
    pb_render(plugin, [], reset=True, duration=0.5)
    if change and not before_lead_in:
        pb_set(plugin, change, CHANGES[change])
    return pb_render(plugin, [NOTE_S], reset=False)


@pytest.mark.parametrize("name", CHANGES)
def test_pedalboard_note_plays_the_object_of_a_change_before_it(vst3_path, name):
    default = pb_stream(vst3_path, None, False)
    assert np.max(np.abs(default)) > 1e-4, "the note is silent"
    starts_with = pb_stream(vst3_path, name, True)
    assert not np.array_equal(starts_with, default), f"{name}: the change is not audible"
    changed = pb_stream(vst3_path, name, False)
    diff = np.max(np.abs(changed - starts_with))
    assert np.array_equal(changed, starts_with), (
        f"{name}: the note after the change differs from a stream that starts with the new "
        f"object by up to {diff} (it played the old object)"
    )


def test_pedalboard_renders_of_one_project_are_identical(vst3_path):
    renders = []
    for _ in range(2):
        plugin = pedalboard.load_plugin(str(vst3_path))
        pb_render(plugin, [], reset=True, duration=0.5)
        for name, value in CHANGES.items():
            pb_set(plugin, name, value)
        renders.append(pb_render(plugin, [NOTE_S, 0.6], reset=False))
    assert np.max(np.abs(renders[0])) > 1e-4
    assert np.array_equal(renders[0], renders[1])
