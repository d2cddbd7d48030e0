"""Child process for test_rt_safety.py: drives a Tactus.vst3 built with `--features rt-checks`
(debug build, nice-plug's `assert_process_allocs`). Any heap allocation inside the plugin's
process call aborts this whole process (SIGABRT, "memory allocation of N bytes failed"), which the
parent test detects. Prints RT-OK at the end if every render completed.

Usage: python rt_child.py <path to Tactus.vst3>
"""

import sys
import time

import dawdreamer as daw
import numpy as np
import pedalboard

from conftest import skip_midi_proxies_in_pedalboard

SR = 48000


def main(path: str) -> None:
    # 1. pedalboard: notes of many keys/velocities, parameters changed between renders, several
    #    block sizes (including odd ones and one larger than typical).
    #    Every parameter the host sees is randomised, including the 2080 MIDI CC / pressure /
    #    pitch-bend proxies of nice-plug's VST3 wrapper (they reach process() as MIDI events).
    #    They are set through pedalboard's native parameter list: its Python wrappers are built
    #    by sampling each parameter's text 1001 times, minutes for 2100 parameters in a debug
    #    build (conftest.skip_midi_proxies_in_pedalboard).
    skip_midi_proxies_in_pedalboard()
    t0 = time.monotonic()
    plugin = pedalboard.load_plugin(path)
    assert len(plugin._parameters) > 2000, "expected the MIDI proxies among the parameters"
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
    print("RT-OK", flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
