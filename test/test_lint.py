"""The tree stays ruff-clean (ruff is a declared test dependency, see setup.py extras)."""
import sys
from pathlib import Path

import process_group

ROOT = Path(__file__).resolve().parent.parent


def test_ruff_clean():
    proc = process_group.run([sys.executable, "-m", "ruff", "check", "--no-cache", str(ROOT)],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
