"""The installable archives of `cargo xtask dist`: each zip named in TACTUS_DIST_ZIPS
(whitespace-separated paths; .ci/test sets it for the Linux archive, .ci/windows for the Windows
one) holds, under one folder `tactus-<version>-<platform>/`, the CLAP and VST3 bundles, the CLI,
README.md, LICENSE and the licence notices, each the file of this checkout where one exists.
Skipped when TACTUS_DIST_ZIPS is not set.
"""

import os
import re
import zipfile
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
ZIPS = os.environ.get("TACTUS_DIST_ZIPS", "").split()


def cargo_version() -> str:
    text = (REPO_ROOT / "Cargo.toml").read_text()
    return re.search(r'^version = "([^"]+)"', text, re.M).group(1)


@pytest.mark.skipif(not ZIPS, reason="set TACTUS_DIST_ZIPS to archives written by cargo xtask dist")
@pytest.mark.parametrize("path", ZIPS)
def test_archive_holds_the_bundles_cli_and_notices(path):
    path = Path(path)
    version = cargo_version()
    m = re.fullmatch(rf"tactus-{re.escape(version)}-(linux|windows|macos)-(x86_64|aarch64)\.zip", path.name)
    assert m, f"{path.name}: not tactus-{version}-<platform>.zip"
    windows = m.group(1) == "windows"
    root = path.name[: -len(".zip")]
    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
        assert all(n.startswith(root + "/") for n in names), "every file under one folder"
        exe = "tactus.exe" if windows else "tactus"
        for f in ["Tactus.clap", exe, "README.md", "LICENSE", "licenses/third-party.md", "licenses/measured-data.txt"]:
            assert f"{root}/{f}" in names, f"{f} missing from {path.name}"
        for f, repo in [
            ("README.md", "README.md"),
            ("LICENSE", "LICENSE"),
            ("licenses/third-party.md", "docs/licenses/third-party.md"),
            ("licenses/measured-data.txt", "docs/licenses/measured-data.txt"),
        ]:
            assert z.read(f"{root}/{f}") == (REPO_ROOT / repo).read_bytes(), f"{f} differs from {repo}"
        # The binaries are the platform's: PE ("MZ") on Windows, ELF elsewhere.
        magic = b"MZ" if windows else b"\x7fELF"
        vst3_bins = [n for n in names if n.startswith(f"{root}/Tactus.vst3/Contents/") and not n.endswith("/")]
        assert vst3_bins, "the VST3 bundle holds no binary"
        arch_dirs = {n.split("/")[3] for n in vst3_bins}
        assert arch_dirs == {"x86_64-win" if windows else "x86_64-linux"}, f"VST3 platform folders {arch_dirs}"
        for n in [f"{root}/Tactus.clap", f"{root}/{exe}", *vst3_bins]:
            data = z.read(n)
            assert data[: len(magic)] == magic, f"{n}: not a {m.group(1)} binary"
        if not windows:
            info = z.getinfo(f"{root}/{exe}")
            assert (info.external_attr >> 16) & 0o111, "the CLI is not executable when unpacked"
