"""Child process for test_rt_safety.py: drives a Tactus.vst3 built with `--features rt-checks`
(debug build, nice-plug's `assert_process_allocs`). Any heap allocation inside the plugin's
process call aborts this whole process (SIGABRT, "memory allocation of N bytes failed"), which the
parent test detects. Prints RT-OK at the end if every render completed.

Usage: python rt_child.py <path to Tactus.vst3>
"""

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import dawdreamer as daw
import numpy as np
import pedalboard

from conftest import find_param, skip_midi_proxies_in_pedalboard

SR = 48000


def worst_case_preset(kind: str, out: Path) -> None:
    """Writes the project's own worst case (`tactus preset worst-case`, `preset::worst_case_preset`
    and its build-up and ring variants: every draw fills the engine's mode limit) to `out`, so this
    test runs the very presets the unit tests' allocation checks do. The CLI is $TACTUS_CLI, else
    target/release/tactus of this checkout."""
    cli = os.environ.get("TACTUS_CLI") or str(Path(__file__).resolve().parents[2] / "target/release/tactus")
    if not Path(cli).is_file():
        raise SystemExit(f"the tactus CLI {cli} does not exist: build it or set TACTUS_CLI")
    subprocess.run([cli, "preset", "worst-case", "--kind", kind, "-o", str(out)], check=True)


def main(path: str) -> None:
    # 1. pedalboard: notes of many keys/velocities, parameters changed between renders, several
    #    block sizes (including odd ones and one larger than typical).
    #    Every parameter the host sees is randomised, including the 32 MIDI CC 1 / channel
    #    pressure proxies of nice-plug's VST3 wrapper (they reach process() as MIDI events),
    #    set through pedalboard's native parameter list.
    skip_midi_proxies_in_pedalboard()
    t0 = time.monotonic()
    plugin = pedalboard.load_plugin(path)
    assert len(plugin._parameters) == 30 + 32, "expected the 32 MIDI proxies beside the parameters"
    rng = np.random.default_rng(1)
    msgs = []
    for i in range(64):
        t = i * 0.03
        key = 24 + (i * 7) % 84
        msgs.append((bytes([0x90, key, 1 + (i * 37) % 127]), t))
        msgs.append((bytes([0x80, key, 0]), t + 0.02))
    total = 0
    for round_, block in enumerate([512, 64, 1000, 4096, 1]):
        # Fetched anew every round: pedalboard re-creates the native parameter objects when it
        # re-prepares the plugin for another block size (cached ones dangle: segfault).
        for p in plugin._parameters:
            p.raw_value = float(rng.uniform())
        dur = 2.0 if block > 1 else 0.1
        audio = plugin(msgs, duration=dur, sample_rate=SR, num_channels=2, buffer_size=block)
        assert np.all(np.isfinite(audio)), f"non-finite output in round {round_}"
        total += audio.shape[1]
        print(
            f"pedalboard block={block} rendered {audio.shape[1]} frames "
            f"({time.monotonic() - t0:.1f} s since load)",
            flush=True,
        )

    # 2. dawdreamer: automation lanes on every parameter, i.e. parameter changes arriving inside
    #    process() while notes play.
    t0 = time.monotonic()
    engine = daw.RenderEngine(SR, 256)
    synth = engine.make_plugin_processor("tactus", path)
    n = synth.get_plugin_parameter_size()
    frames = 2 * SR
    t = np.arange(frames) / SR
    for i in range(n):
        lane = 0.5 + 0.5 * np.sin(2 * np.pi * (0.5 + i * 0.37) * t + i)
        synth.set_automation(i, lane.astype(np.float32))
    for i in range(40):
        synth.add_midi_note(30 + (i * 5) % 70, 20 + (i * 13) % 107, i * 0.045, 0.03)
    engine.load_graph([(synth, [])])
    engine.render(2.0)
    audio = np.asarray(synth.get_audio())
    assert np.all(np.isfinite(audio))
    print(
        f"dawdreamer automated {n} parameters, rendered {audio.shape[1]} frames "
        f"({time.monotonic() - t0:.1f} s)",
        flush=True,
    )
    print(f"peak {np.max(np.abs(audio)):.3g}", flush=True)

    # 3. The project's worst-case presets (plain, building up, ringing after the knock) as user
    #    presets, a new object before every render and several block sizes: objects are drawn by the plugin's worker thread (or in place when the host
    #    renders offline), never by an allocating or unbounded path inside process().
    t0 = time.monotonic()
    for kind in ["build-up", "ring", "plain"]:
        with tempfile.TemporaryDirectory() as tmp:
            worst = Path(tmp) / "worst.json"
            worst_case_preset(kind, worst)
            os.environ["TACTUS_USER_PRESET"] = str(worst)
            plugin = pedalboard.load_plugin(path)
            del os.environ["TACTUS_USER_PRESET"]
        mat_attr, _ = find_param(plugin, "Material")
        new_attr, _ = find_param(plugin, "New Object")
        blocks = [64, 512, 1000, 1, 4096, 333] if kind == "plain" else [512, 1]
        for i, block in enumerate(blocks):
            setattr(plugin, mat_attr, "User Preset")
            setattr(plugin, new_attr, i % 2 == 0)
            dur = 0.5 if block > 1 else 0.05
            audio = plugin(msgs, duration=dur, sample_rate=SR, num_channels=2, buffer_size=block)
            assert np.all(np.isfinite(audio)), f"non-finite output with the {kind} worst case, block {block}"
        print(f"worst-case user preset ({kind}) rendered ({time.monotonic() - t0:.1f} s)", flush=True)
    # Gestures on the worst-case preset: 64 fragments drawn (by the worker, or in place offline)
    # while notes bounce, break and rattle.
    gesture_attr, _ = find_param(plugin, "Gesture")
    fragments_attr, _ = find_param(plugin, "Fragments")
    setattr(plugin, fragments_attr, 64)
    for gesture in ["Bounce", "Break", "Rattle", "Break"]:
        setattr(plugin, gesture_attr, gesture)
        setattr(plugin, new_attr, gesture == "Rattle")
        audio = plugin(msgs, duration=0.5, sample_rate=SR, num_channels=2, buffer_size=512)
        assert np.all(np.isfinite(audio)), f"non-finite output in {gesture} with the worst-case preset"
    print(f"worst-case user preset rendered, gestures included ({time.monotonic() - t0:.1f} s)", flush=True)
    print("RT-OK", flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
