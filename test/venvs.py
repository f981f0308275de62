"""Fresh venvs the tests build as a user would (test_lean_install.py, test_launch.py): from a
copy of this tree as a clone has it, with pip; skipped with the reason when the package
registry cannot be reached."""
from __future__ import annotations

import shutil
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import process_group
import pytest
from conftest import REPO

# What pip says when it cannot reach an index (no network, proxy or DNS down).
UNREACHABLE = ("NewConnectionError", "Network is unreachable", "Temporary failure in name "
               "resolution", "No matching distribution found", "ConnectTimeout", "ProxyError")


def unreachable(out: str) -> str | None:
    """pip's last line saying that it could not reach an index, if any."""
    lines = [line for line in out.splitlines() if any(s in line for s in UNREACHABLE)]
    return lines[-1].strip() if lines else None


def tree_copy(dest: Path) -> Path:
    """The files of this tree a clone would have (tracked and new, edits included)."""
    if shutil.which("git") is None:
        pytest.skip("git is needed to copy the tree as a clone has it")
    listed = subprocess.run(["git", "ls-files", "-z", "-co", "--exclude-standard"], cwd=REPO,
                            capture_output=True, check=True, timeout=60).stdout
    for name in filter(None, listed.decode().split("\0")):
        src = REPO / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)
    return dest


def new_venv(root: Path) -> Path:
    """A fresh venv at `root` (of this Python's version); its bin/ folder."""
    process_group.run([sys.executable, "-m", "venv", str(root)], check=True, timeout=120)
    return root / "bin"


def pip_install(bin_dir: Path, args: Sequence[str], timeout: float) -> None:
    """`pip install -q ARGS` into the venv of `bin_dir`; a skip when the registry is
    unreachable, a failure with pip's last lines otherwise."""
    start = time.monotonic()
    pip = process_group.run([str(bin_dir / "python"), "-m", "pip", "install", "-q", *args],
                            capture_output=True, text=True, timeout=timeout)
    if pip.returncode != 0 and (line := unreachable(pip.stdout + pip.stderr)):
        pytest.skip(f"the package registry is unreachable: {line[:200]}")
    assert pip.returncode == 0, (pip.stdout + pip.stderr)[-3000:]
    print(f"pip install {' '.join(args)[:100]}: {time.monotonic() - start:.1f} s")
