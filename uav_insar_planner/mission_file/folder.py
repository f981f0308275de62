"""The folder of an export: what stands in the way of its files, and writing the whole set or
nothing.

`folder_problems` looks at every name an export touches before anything is written: each file
to write must be absent or a regular, writable file; a stale `uavK.plan` (a UAV of the swarm's
largest size that this export does not fly, left by an earlier export of more UAVs or another
scheme) must be a QGroundControl plan, so that removing it removes a mission file and nothing
else. `replace_files` then writes every file to a temporary in the folder, moves each old
file (replaced or stale) aside, renames the temporaries into place and only then deletes what
was moved aside; on any failure it undoes every step, so the folder is left as it was (and a
folder it made is removed again).
"""
from __future__ import annotations

import json
import os
import secrets
from collections.abc import Iterable, Mapping
from pathlib import Path

from uav_insar_planner.params import shown

# a stale file is read only to tell a plan from anything else; a plan of 6 items is ~5 kB
STALE_READ_MAX_BYTES = 1 << 20


def _is_plan(path: Path) -> bool:
    """Whether `path` holds a QGroundControl plan (JSON with fileType Plan)."""
    try:
        with open(path, "rb") as f:
            doc = json.loads(f.read(STALE_READ_MAX_BYTES))
    except (OSError, ValueError):
        return False
    return isinstance(doc, dict) and doc.get("fileType") == "Plan"


def folder_problems(option: str, folder: Path, names: Iterable[str],
                    stale: Iterable[str]) -> list[str]:
    """One line per entry of `folder` in the way: a name of `names` (to be written) that is
    not a writable regular file, or a name of `stale` (to be removed) present but not a
    QGroundControl plan. A folder not made yet has nothing in the way."""
    if not folder.is_dir():
        return []
    problems, where = [], f"in {shown(str(folder))}"
    for name in names:
        path = folder / name
        if not os.path.lexists(path):
            continue
        if path.is_symlink() or not path.is_file():
            problems.append(f"{option}: {name} {where} is in the way: it exists and is not a "
                            "regular file; expected a file this export may replace, or none")
        elif not os.access(path, os.W_OK):
            problems.append(f"{option}: {name} {where} is read-only; expected a writable "
                            "file this export may replace, or none")
    for name in stale:
        path = folder / name
        if not os.path.lexists(path):
            continue
        if path.is_symlink() or not path.is_file() or not _is_plan(path):
            problems.append(f"{option}: {name} {where} is in the way: a stale name of this "
                            "export that is not a QGroundControl plan, so it is not removed; "
                            "expected it moved away")
        elif not os.access(path, os.W_OK):
            problems.append(f"{option}: {name} {where} is a stale plan of an earlier export "
                            "and read-only, so it is not removed; expected it writable or "
                            "moved away")
    return problems


def _missing_parents(folder: Path) -> list[Path]:
    """The folders `folder.mkdir(parents=True)` would make, outermost first."""
    missing = []
    while not folder.exists():
        missing.append(folder)
        folder = folder.parent
    return missing[::-1]


def replace_files(folder: Path, texts: Mapping[str, str | bytes], stale: Iterable[str]
                  ) -> list[str]:
    """Write `texts` (name -> content: text, or bytes as they are) into `folder` and remove the
    `stale` names present,
    all or nothing; returns the stale names removed. When any step fails, every step is
    undone and OSError is raised with `filename` the name (of `texts` or `stale`, or the
    folder) whose step failed."""
    made = _missing_parents(folder)
    token = secrets.token_hex(4)
    temps: dict[str, Path] = {}
    aside: dict[str, Path] = {}
    placed: list[str] = []
    current = str(folder)
    try:
        for path in made:
            path.mkdir()
        for current, text in texts.items():
            temp = folder / f".{current}.{token}.new"
            binary = isinstance(text, bytes)
            with open(temp, "xb" if binary else "x", encoding=None if binary else "utf-8") as f:
                temps[current] = temp  # (ours from here: removed again on failure)
                f.write(text)
        for current in [*texts, *stale]:
            if os.path.lexists(folder / current):
                os.rename(folder / current, folder / f".{current}.{token}.old")
                aside[current] = folder / f".{current}.{token}.old"
        for current, temp in temps.items():
            os.rename(temp, folder / current)
            placed.append(current)
    except OSError as exc:
        _undo(folder, temps, aside, placed, made)
        raise OSError(exc.errno, exc.strerror or str(exc), current) from exc
    for path in aside.values():
        os.unlink(path)
    return [name for name in stale if name in aside]


def _undo(folder: Path, temps: Mapping[str, Path], aside: Mapping[str, Path],
          placed: list[str], made: list[Path]) -> None:
    """Put `folder` back as it was: the placed files and the temporaries removed, the files
    moved aside back, the folders made removed (each step best effort: the first failure is
    the one reported)."""
    for name in placed:
        _quietly(os.unlink, folder / name)
    for name, temp in temps.items():
        if name not in placed:
            _quietly(os.unlink, temp)
    for name, old in aside.items():
        _quietly(os.rename, old, folder / name)
    for path in reversed(made):
        _quietly(os.rmdir, path)


def _quietly(step, *paths: Path) -> None:
    try:
        step(*paths)
    except OSError:
        pass
