"""The editor opens and closes repeatedly in a real host (pedalboard's `show_editor`, JUCE) on a
headless X server (`xvfb-run`), and closing/reopening leaks nothing (issue requirement).

The host runs in a child process (editor_child.py) so an X error or crash fails the test instead
of killing pytest. Skipped without `xvfb-run`.
"""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

CYCLES = 12
OPEN_S = 0.5
# Steady state is measured from cycle WARMUP on: the first opens load fonts, GL/llvmpipe shader
# caches and JUCE's window classes once per process.
WARMUP = 3
# Bounded growth over the remaining cycles: 1 MB per cycle of RSS (one 980×620 RGBA frame is
# 2.4 MB, so a leaked framebuffer or GL context per open exceeds it) and no descriptor at all.
RSS_PER_CYCLE_KB = 1024


def run_child(vst3_path):
    child = Path(__file__).with_name("editor_child.py")
    proc = subprocess.run(
        ["xvfb-run", "-a", sys.executable, str(child), str(vst3_path), str(CYCLES), str(OPEN_S)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    print(proc.stdout)
    print(proc.stderr[-3000:])
    assert proc.returncode == 0, f"host process died with {proc.returncode}"
    assert "EDITOR-OK" in proc.stdout
    rows = [
        tuple(map(int, m))
        for m in re.findall(r"CYCLE (\d+) RSS_KB (\d+) THREADS (\d+) FDS (\d+)", proc.stdout)
    ]
    assert len(rows) == CYCLES
    return rows


needs_xvfb = pytest.mark.skipif(shutil.which("xvfb-run") is None, reason="needs xvfb-run (Xvfb)")


@pytest.fixture(scope="module")
def cycles(vst3_path):
    return run_child(vst3_path)


@needs_xvfb
def test_editor_opens_and_closes_repeatedly(cycles):
    # Every cycle opened the window, drew for OPEN_S and closed it without an X error or crash;
    # no thread survives a closed window.
    threads = [t for _, _, t, _ in cycles]
    assert threads[-1] <= threads[WARMUP], threads


@needs_xvfb
@pytest.mark.xfail(
    strict=True,
    reason="each open/close leaks one socketpair (2 fds) in nice-plug 0.4.2's VST3 wrapper: "
    "IPlugView::setFrame creates a RunLoopEventHandler (src/wrapper/vst3/view.rs) whose "
    "socketpair is closed and run-loop registration removed only in its Drop, which never runs "
    "(it holds a raw COM reference to itself). RSS also grows ~5 MB/cycle under Xvfb/llvmpipe "
    "(146 → 259 MB in 12 cycles), not attributed yet",
)


def test_editor_close_reopen_leaks_nothing(cycles):
    rss = [r for _, r, _, _ in cycles]
    fds = [f for _, _, _, f in cycles]
    n = CYCLES - 1 - WARMUP
    rss_growth = (rss[-1] - rss[WARMUP]) / n
    print(f"RSS growth {rss_growth:.0f} KB/cycle; descriptors {fds[WARMUP]} → {fds[-1]}")
    assert fds[-1] == fds[WARMUP], fds
    assert rss_growth < RSS_PER_CYCLE_KB, rss
