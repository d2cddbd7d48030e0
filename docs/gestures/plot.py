"""Waveform and spectrogram of each gesture's example scene (docs/model.md §11).

Reproduce (from the repository root; numpy and matplotlib):
    for g in bounce break rattle; do
        cargo run --release -- render scenes/$g.json --format float32 -o target/$g.wav
    done
    python3 docs/gestures/plot.py target/bounce.wav target/break.wav target/rattle.wav
writes docs/gestures/<name>.png.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np


def read_float32_wav(path):
    """Left channel and rate of a WAVE_FORMAT_IEEE_FLOAT file (`--format float32`)."""
    data = Path(path).read_bytes()
    pos, fmt = 12, None
    while pos + 8 <= len(data):
        cid, size = data[pos:pos + 4], int.from_bytes(data[pos + 4:pos + 8], "little")
        body = data[pos + 8:pos + 8 + size]
        if cid == b"fmt ":
            fmt = body
        elif cid == b"data":
            channels = int.from_bytes(fmt[2:4], "little")
            rate = int.from_bytes(fmt[4:8], "little")
            return np.frombuffer(body, dtype="<f4").reshape(-1, channels)[:, 0], rate
        pos += 8 + size + (size & 1)
    raise SystemExit(f"{path}: no data chunk")


for wav in sys.argv[1:]:
    x, sr = read_float32_wav(wav)
    name = Path(wav).stem
    t = np.arange(len(x)) / sr
    fig, (a, b) = plt.subplots(2, 1, figsize=(9, 5), sharex=True, gridspec_kw={"height_ratios": [1, 2]})
    a.plot(t, x, lw=0.4, color="k")
    a.set_ylabel("amplitude")
    a.set_title(f"scenes/{name}.json")
    # The engine puts silent voices to sleep, so stretches are exactly zero: their -inf dB
    # would be drawn in the "bad" colour (white); draw them as the floor instead.
    cmap = plt.get_cmap("magma").copy()
    cmap.set_bad(cmap(0.0))
    b.specgram(x, NFFT=1024, Fs=sr, noverlap=768, cmap=cmap, vmin=-140, scale="dB")
    b.set_ylabel("Hz")
    b.set_xlabel("s")
    b.set_ylim(0, 16000)
    fig.tight_layout()
    out = Path(__file__).parent / f"{name}.png"
    fig.savefig(out, dpi=90)
    print("wrote", out)
