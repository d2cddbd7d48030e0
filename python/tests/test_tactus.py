"""Tests of the tactus Python module against the `tactus` CLI.

The CLI is $TACTUS_CLI, else target/release/tactus of this checkout; tests that compare with it
are SKIPPED (with the reason shown by `pytest -rs`) when it is absent, and fail when
$TACTUS_CLI names a missing file. Recordings are $TACTUS_RECORDINGS, else ../shared/recordings
beside the checkout.
"""

import json
import os
import shutil
import signal
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import tactus

REPO = Path(__file__).resolve().parents[2]


def _cli():
    env = os.environ.get("TACTUS_CLI")
    if env:
        assert Path(env).is_file(), f"TACTUS_CLI={env} does not exist"
        return env
    p = REPO / "target" / "release" / "tactus"
    return str(p) if p.is_file() else None


CLI = _cli()
needs_cli = pytest.mark.skipif(
    CLI is None,
    reason="SKIPPED: tactus CLI not found (set TACTUS_CLI or cargo build --release --bin tactus)",
)


def run_cli(*args, ok=True):
    r = subprocess.run([CLI, *map(str, args)], capture_output=True, text=True)
    if ok:
        assert r.returncode == 0, r.stderr
    return r


def cli_error(*args):
    """The CLI's one-line error message (stderr without the `error: ` prefix)."""
    r = run_cli(*args, ok=False)
    assert r.returncode != 0
    lines = [l for l in r.stderr.splitlines() if l.startswith("error: ")]
    assert len(lines) == 1, r.stderr
    return lines[0][len("error: "):]


def read_float32_wav(path):
    """(frames, channels) float32 samples and the rate of a WAVE_FORMAT_IEEE_FLOAT file (the
    stdlib `wave` module reads PCM only)."""
    data = Path(path).read_bytes()
    assert data[:4] == b"RIFF" and data[8:12] == b"WAVE"
    pos, fmt = 12, None
    while pos + 8 <= len(data):
        cid, size = data[pos:pos + 4], int.from_bytes(data[pos + 4:pos + 8], "little")
        body = data[pos + 8:pos + 8 + size]
        if cid == b"fmt ":
            fmt = body
        elif cid == b"data":
            tag = int.from_bytes(fmt[0:2], "little")
            channels = int.from_bytes(fmt[2:4], "little")
            rate = int.from_bytes(fmt[4:8], "little")
            bits = int.from_bytes(fmt[14:16], "little")
            assert (tag, bits) == (3, 32), (tag, bits)
            return np.frombuffer(body, dtype="<f4").reshape(-1, channels), rate
        pos += 8 + size + (size & 1)
    raise AssertionError(f"{path}: no data chunk")


def short_scene(duration_s=0.3, **extra):
    scene = {
        "sample_rate": 48000,
        "duration_s": duration_s,
        "seed": 3,
        "material": "wood",
        "events": [{"type": "impact", "time_s": 0.01, "velocity_m_per_s": 1.0}],
    }
    scene.update(extra)
    return scene


# --- render -------------------------------------------------------------------------------


@needs_cli
def test_render_demo_equals_cli_float32_render(tmp_path):
    wav = tmp_path / "demo.wav"
    run_cli("render", "--demo", "--format", "float32", "-o", wav)
    expected, rate = read_float32_wav(wav)
    for scene in (tactus.DEMO_SCENE, REPO / "scenes" / "demo.json", json.loads(tactus.DEMO_SCENE)):
        audio, sr = tactus.render(scene)
        assert sr == rate == 48000
        assert audio.dtype == np.float32 and audio.shape == expected.shape == (8 * 48000, 2)
        assert np.array_equal(audio, expected), "render differs from the CLI's float32 render"
    assert np.abs(audio).max() > 0.01
    audio[0, 0] = 1.0  # the array is the caller's own (writable)


@needs_cli
def test_render_block_size_matches_cli(tmp_path):
    wav = tmp_path / "b.wav"
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(short_scene(0.5)))
    run_cli("render", scene, "--format", "float32", "--block", 37, "-o", wav)
    expected, _ = read_float32_wav(wav)
    audio, _ = tactus.render(scene, block=37)
    assert np.array_equal(audio, expected)


def test_stems_sum_to_the_mix():
    scene = {
        "sample_rate": 48000,
        "duration_s": 0.4,
        "objects": {"pan": {"material": "metal", "seed": 11}, "board": {"material": "wood"}},
        "events": [
            {"type": "impact", "object": "pan", "time_s": 0.01, "velocity_m_per_s": 1.0},
            {"type": "impact", "object": "board", "time_s": 0.2, "velocity_m_per_s": 2.0},
        ],
    }
    audio, sr, stems = tactus.render(scene, stems=True)
    assert sr == 48000 and sorted(stems) == ["board", "pan"]
    # The mix is the stems summed in name order, in float32.
    assert np.array_equal(stems["board"] + stems["pan"], audio)
    assert np.abs(stems["pan"][: int(0.2 * sr)]).max() > 0
    assert not np.any(stems["board"][: int(0.2 * sr) - 1])
    mono, _, one = tactus.render(short_scene(), stems=True)
    assert list(one) == ["object"] and np.array_equal(one["object"], mono)


def test_gestures_render_and_are_checked():
    events = [
        {"type": "bounce", "time_s": 0.0, "height_m": 0.2, "restitution": 0.5},
        {"type": "break", "time_s": 0.3, "velocity_m_per_s": 2.0, "fragments": 3, "seed": 4},
        {"type": "rattle", "time_s": 0.5, "duration_s": 0.2, "objects": 2, "rate_hz": 20},
    ]
    audio, sr = tactus.render(short_scene(0.8, events=events))
    assert np.isfinite(audio).all() and np.abs(audio).max() > 0.01
    again, _ = tactus.render(json.dumps(short_scene(0.8, events=events)))
    assert np.array_equal(audio, again), "gestures are deterministic"
    bad = [{"type": "break", "time_s": 0.0, "fragments": 65}]
    with pytest.raises(ValueError, match=r"events\[0\]\.fragments"):
        tactus.render(short_scene(events=bad))


CEILING = 10 ** (-0.3 / 20)


def test_render_limit_caps_loud_renders_and_leaves_quiet_ones_alone():
    loud = short_scene(0.5, settings={"gain_db": 24}, events=[
        {"type": "impact", "time_s": 0.01, "velocity_m_per_s": 10.0},
    ])
    unlimited, _ = tactus.render(loud)
    limited, _ = tactus.render(loud, limit=True)
    assert np.abs(unlimited).max() > 1.0, "the test needs a render above full scale"
    assert np.isfinite(limited).all() and np.abs(limited).max() <= np.float32(CEILING)
    quiet = short_scene(0.5, settings={"gain_db": -24})
    a, _ = tactus.render(quiet)
    b, _ = tactus.render(quiet, limit=True)
    assert 0 < np.abs(a).max() < CEILING / 2
    assert np.array_equal(a, b), "quiet material must pass bit-identical"


@needs_cli
def test_render_limit_matches_cli(tmp_path):
    wav = tmp_path / "l.wav"
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(short_scene(0.5, settings={"gain_db": 24})))
    run_cli("render", scene, "--format", "float32", "--limit", "-o", wav)
    expected, _ = read_float32_wav(wav)
    audio, _ = tactus.render(scene, limit=True)
    assert np.array_equal(audio, expected)
    assert np.abs(audio).max() <= np.float32(CEILING)


def ctrl_c_after(seconds):
    """A timer that sends this process SIGINT (Ctrl-C) after `seconds`. Python's own handler is
    installed first: a process started as a background job of a non-interactive shell inherits
    SIGINT ignored, and the signal would then never reach the call under test."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    return threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT))


def test_render_is_interrupted_by_ctrl_c():
    # An hour of rolling keeps the engine busy throughout (minutes to render).
    roll = {"type": "roll", "time_s": 0.0, "duration_s": 3600.0, "speed_m_per_s": 0.5,
            "pressure_n": 2.0, "radius_m": 0.03}
    scene = short_scene(3600.0, events=[roll])
    timer = ctrl_c_after(0.3)
    t0 = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            tactus.render(scene)
    finally:
        timer.cancel()
    # The render stopped at Ctrl-C, not at its end.
    assert time.monotonic() - t0 < 5.0


# --- errors -------------------------------------------------------------------------------


@needs_cli
def test_errors_carry_the_cli_messages(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(short_scene(sample_rate=1000)))
    with pytest.raises(ValueError) as e:
        tactus.render(bad)
    assert str(e.value) == cli_error("render", bad, "-o", tmp_path / "x.wav")
    assert "sample_rate" in str(e.value)

    missing = tmp_path / "missing.json"
    with pytest.raises(FileNotFoundError) as e:
        tactus.render(missing)
    assert str(e.value) == cli_error("render", missing, "-o", tmp_path / "x.wav")

    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"scene": short_scene(), "samples": 0}))
    with pytest.raises(ValueError) as e:
        tactus.batch(spec, tmp_path / "out")
    assert str(e.value) == cli_error("batch", spec, "-o", tmp_path / "out")

    with pytest.raises(OSError) as e:
        tactus.fit([tmp_path / "nothing.wav"], material="wood")
    assert str(e.value) == cli_error("fit", tmp_path / "nothing.wav", "--material", "wood", "-o", tmp_path / "p.json")


def test_bad_inputs_raise_python_exceptions(tmp_path):
    with pytest.raises(ValueError, match="invalid scene JSON"):
        tactus.render("{not json")
    with pytest.raises(ValueError, match="sample_rate"):
        tactus.render(short_scene(sample_rate=1))
    with pytest.raises(ValueError, match="unknown material|material"):
        tactus.render(short_scene(material="unobtainium"))
    with pytest.raises(ValueError, match="scene must be a dict"):
        tactus.render(42)
    with pytest.raises(ValueError, match="not JSON-serialisable"):
        tactus.render({"sample_rate": object()})
    with pytest.raises(ValueError, match="block"):
        tactus.render(short_scene(), block=0)
    with pytest.raises(OSError):
        tactus.render(tmp_path / "no-such-scene.json")
    with pytest.raises(ValueError, match="shard"):
        tactus.batch({"scene": short_scene()}, tmp_path / "o", shard="2/2")
    with pytest.raises(ValueError, match="format"):
        tactus.batch({"scene": short_scene()}, tmp_path / "o", format="mp3")
    with pytest.raises(ValueError, match="spec \\(dict\\): params\\[0\\]"):
        tactus.batch({"scene": short_scene(), "params": [{"path": "x", "uniform": [0, 1]}]}, tmp_path / "o")
    with pytest.raises(OSError):
        tactus.batch(tmp_path / "no-such-spec.json", tmp_path / "o")
    with pytest.raises(ValueError, match="modes"):
        tactus.fit(tmp_path, material="wood", modes=1)
    with pytest.raises(ValueError, match="no features"):
        tactus.features(np.zeros(48000), 48000)
    with pytest.raises(ValueError, match="1-D"):
        tactus.features(np.zeros((2, 2, 2)), 48000)


def test_materials_are_the_scene_names():
    names = tactus.materials()
    assert "Wood" in names and "Metal" in names and len(names) == len(set(names))
    for n in names:
        tactus.render(short_scene(0.05, material=n.lower()))


def test_surfaces_are_the_scene_names():
    names = tactus.surfaces()
    assert names[0] == "synthetic" and "sandpaper" in names and len(names) == 13
    for n in names:
        scrape = {"type": "scrape", "time_s": 0.0, "duration_s": 0.05, "speed_m_per_s": 0.5,
                  "surface": n}
        y, _ = tactus.render(short_scene(0.05, events=[scrape]))
        assert np.isfinite(y).all()
    with pytest.raises(ValueError, match="velvet"):
        tactus.render(short_scene(0.05, events=[dict(scrape, surface="velvet")]))


# --- batch --------------------------------------------------------------------------------


def spec_dict(samples=6):
    return {
        "scene": short_scene(0.2),
        "samples": samples,
        "seed": 5,
        "params": [{"path": "/events/0/velocity_m_per_s", "uniform": [0.5, 3.0]}],
    }


def files_of(d):
    return {p.name: p.read_bytes() for p in sorted(Path(d).glob("*.wav"))}


def test_batch_two_shards_equal_one_run(tmp_path):
    whole, sharded = tmp_path / "whole", tmp_path / "sharded"
    s = tactus.batch(spec_dict(), whole, threads=2)
    assert s["rendered"] == 6 and s["skipped"] == 0
    assert Path(s["manifest"]) == whole / "manifest.jsonl"
    a = tactus.batch(spec_dict(), sharded, shard="0/2")
    b = tactus.batch(json.dumps(spec_dict()), sharded, threads=1, shard=(1, 2))
    assert a["rendered"] == 3 and b["rendered"] == 3
    assert files_of(whole) == files_of(sharded) and len(files_of(whole)) == 6
    rows = [json.loads(l) for l in (whole / "manifest.jsonl").read_text().splitlines()]
    s0 = (sharded / "manifest-shard-0-of-2.jsonl").read_text().splitlines()
    s1 = (sharded / "manifest-shard-1-of-2.jsonl").read_text().splitlines()
    interleaved = [json.loads(l) for pair in zip(s0, s1) for l in pair]
    assert interleaved == rows and [r["index"] for r in rows] == list(range(6))
    if CLI:
        run_cli("merge-manifests", sharded)
        for ext in ("jsonl", "csv"):
            assert (sharded / f"manifest.{ext}").read_bytes() == (whole / f"manifest.{ext}").read_bytes()
    # A rerun resumes: every file is already there.
    again = tactus.batch(spec_dict(), whole)
    assert again["rendered"] == 0 and again["skipped"] == 6


@needs_cli
def test_batch_equals_cli_batch(tmp_path):
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps(spec_dict(4)))
    run_cli("batch", spec, "-o", tmp_path / "cli", "--format", "float32")
    tactus.batch(spec, tmp_path / "py", format="float32")
    assert files_of(tmp_path / "cli") == files_of(tmp_path / "py")
    for name in ("manifest.jsonl", "manifest.csv", "batch.json"):
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes()


def test_batch_is_interrupted_by_ctrl_c(tmp_path):
    out = tmp_path / "o"
    timer = ctrl_c_after(0.5)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            tactus.batch(spec_dict(100_000), out, threads=1)
    finally:
        timer.cancel()
    assert not (out / "manifest.jsonl").exists()
    assert 0 < len(list(out.glob("*.wav"))) < 100_000


# --- fit and features ---------------------------------------------------------------------


def recordings():
    env = os.environ.get("TACTUS_RECORDINGS")
    d = Path(env) if env else REPO.parent / "shared" / "recordings"
    if not d.is_dir():
        pytest.skip(f"SKIPPED: recordings not found at {d} (set TACTUS_RECORDINGS)")
    return d


def test_fit_two_recordings(tmp_path):
    d = recordings()
    files = [d / "wood_marimba_fluidr3_marimba-c-5.wav", d / "wood_marimba_fluidr3_marimba-f-5.wav"]
    for f in files:
        if not f.is_file():
            pytest.skip(f"SKIPPED: {f} not found")
    out = tmp_path / "fitted.json"
    preset = tactus.fit([str(f) for f in files], material="wood", name="Two Marimbas", out=out)
    assert preset["name"] == "Two Marimbas" and preset["material_class"] == "wood"
    assert json.loads(out.read_text()) == preset
    if CLI:
        cli_out = tmp_path / "cli.json"
        run_cli("fit", *files, "--material", "wood", "--name", "Two Marimbas", "-o", cli_out)
        assert cli_out.read_bytes() == out.read_bytes()
    # The fitted preset renders.
    audio, _ = tactus.render(short_scene(0.5, material={"preset_file": str(out)}))
    assert np.abs(audio).max() > 0


def test_fit_reads_every_recording_format(tmp_path):
    fixtures = REPO / "tests" / "fixtures"
    fit = lambda ext: tactus.fit(fixtures / f"cowbell.{ext}", material="metal", modes=8, strict=True)
    wav = json.dumps(fit("wav"))
    for ext in ("flac", "aiff"):
        # Lossless: the WAV's preset, file names in the provenance aside.
        assert json.dumps(fit(ext)).replace(f"cowbell.{ext}", "cowbell.wav") == wav
    for ext in ("ogg", "mp3"):
        assert fit(ext)["origin"] == "fitted"
    cut = tmp_path / "cut.flac"
    data = (fixtures / "cowbell.flac").read_bytes()
    cut.write_bytes(data[: len(data) * 3 // 5])
    with pytest.raises(ValueError, match=r"cut\.flac: truncated or damaged FLAC stream"):
        tactus.fit(cut, material="metal")
    if CLI:
        assert "cut.flac: truncated or damaged FLAC stream" in cli_error("fit", cut, "--material", "metal", "-o", tmp_path / "p.json")


def test_features_of_a_render():
    audio, sr = tactus.render(short_scene(2.0, material="metal"))
    f = tactus.features(audio, sr)
    assert list(f) == ["centroid_hz", "tan_phi", "t60_s", "decay_slope", "attack_share", "edt_s", "peak_count"]
    assert all(np.isfinite(v) for v in f.values())
    assert 50 < f["centroid_hz"] < 9000 and f["peak_count"] >= 2
    # Stereo is mixed to mono by the channel mean, as `tactus eval` does.
    assert tactus.features(audio.astype(np.float64).mean(axis=1), sr) == f
    # Different materials give different features.
    wood, _ = tactus.render(short_scene(2.0, material="wood"))
    assert tactus.features(wood, sr) != f
