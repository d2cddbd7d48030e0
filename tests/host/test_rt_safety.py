"""Real-time safety: no heap allocation inside process().

Needs a debug bundle built with nice-plug's `assert_process_allocs` (Cargo feature `rt-checks`):

    cargo xtask bundle tactus --features rt-checks     # debug build into target/bundled
    mkdir -p target/rtcheck && cp -r target/bundled/tactus.vst3 target/rtcheck/
    TACTUS_VST3_RTCHECK=target/rtcheck/tactus.vst3 pytest tests/host -k rt_safety

(`nice-assert-no-alloc` runs in abort mode in debug builds: an allocation inside process() calls
`std::alloc::handle_alloc_error`, which prints "memory allocation of N bytes failed" and aborts
the host process with SIGABRT. The render therefore runs in a child process.)
Skipped when TACTUS_VST3_RTCHECK is not set.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import bundle_from_env, require_bundle


@pytest.mark.skipif(
    not os.environ.get("TACTUS_VST3_RTCHECK"),
    reason="set TACTUS_VST3_RTCHECK to a Tactus.vst3 built with --features rt-checks",
)
def test_process_never_allocates():
    path = require_bundle(bundle_from_env("TACTUS_VST3_RTCHECK", None), "TACTUS_VST3_RTCHECK")
    child = Path(__file__).with_name("rt_child.py")
    proc = subprocess.run(
        [sys.executable, str(child), str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    print(proc.stdout)
    print(proc.stderr[-4000:])
    assert "memory allocation" not in proc.stderr, "allocation inside process()"
    assert proc.returncode == 0, f"host process died with {proc.returncode}"
    assert "RT-OK" in proc.stdout
