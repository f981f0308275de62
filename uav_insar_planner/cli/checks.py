"""Checks of `uav-insar` arguments made before any work starts, each failing with one line.

Output paths are tried for writing up front (a sweep's results must not be lost to a typo in
`--csv` after an hour of solving); sweep values must be finite and their count bounded.
"""
from __future__ import annotations

import argparse
import math
import os
import shutil
import tempfile
from datetime import datetime, timedelta, timezone
from pathlib import Path
from urllib.parse import urlsplit

from uav_insar_planner.params import SCHEMES, ParamError, shown
from uav_insar_planner.study.executors import jobs_max

SWEEP_COUNT_MAX = 10_000  # evenly spaced values per sweep; each costs a solve per scheme
# Solves of a map (COUNT1 x COUNT2 x schemes): as many as the largest sweep may ask for.
MAP_SOLVES_MAX = SWEEP_COUNT_MAX * len(SCHEMES)
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss")  # the Dask transports a scheduler listens on
# How far ahead a UTC instant may be: NAV_DELAY holds an hour of day, not a date, and a
# HH:MM:SS instant is today's.
INSTANT_AHEAD_MAX = timedelta(hours=24)


def sweep_count(text: str) -> int:
    """argparse type of the sweep COUNT: an integer in 1..SWEEP_COUNT_MAX."""
    stripped = text.strip()
    if not (stripped.lstrip("+-").isdigit() and len(stripped) <= 12
            and 1 <= int(stripped) <= SWEEP_COUNT_MAX):
        raise argparse.ArgumentTypeError(f"value {shown(text)} is not allowed; expected an "
                                         f"integer in 1..{SWEEP_COUNT_MAX}")
    return int(stripped)


def jobs_count(text: str) -> int:
    """argparse type of --jobs: an integer in 1..executors.jobs_max() (per core, a bound)."""
    stripped, most = text.strip(), jobs_max()
    if not (stripped.lstrip("+-").isdigit() and len(stripped) <= 12
            and 1 <= int(stripped) <= most):
        raise argparse.ArgumentTypeError(f"value {shown(text)} is not allowed; expected an "
                                         f"integer in 1..{most} (worker processes, at most "
                                         f"{most // (os.cpu_count() or 1)} per core here)")
    return int(stripped)


def scheduler_address(text: str) -> str:
    """argparse type of --scheduler: SCHEME://HOST:PORT of a Dask scheduler."""
    try:
        parts = urlsplit(text)
        ok = (parts.scheme in SCHEDULER_SCHEMES and bool(parts.hostname)
              and parts.port is not None and parts.port > 0 and parts.path in ("", "/")
              and not parts.query and not parts.fragment)
    except ValueError:  # a port out of 0..65535 or not a number
        ok = False
    if not ok:
        raise argparse.ArgumentTypeError(
            f"value {shown(text)} is not allowed; expected SCHEME://HOST:PORT of a Dask "
            f"scheduler, SCHEME one of {', '.join(SCHEDULER_SCHEMES)}, e.g. "
            "tcp://127.0.0.1:8786")
    return text


def finite_float(text: str) -> float:
    """argparse type of a sweep START / STOP: a finite number."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"value {shown(text)} is not allowed; expected a "
                                         "finite number")
    return value


def image_formats() -> list[str]:
    """File extensions matplotlib can save to here (pgf only with a LaTeX to measure text)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    formats = set(Figure().canvas.get_supported_filetypes())
    if shutil.which(matplotlib.rcParams["pgf.texsystem"]) is None:
        formats.discard("pgf")
    return sorted(formats)


def check_output_path(option: str, path: str, image: bool = False) -> None:
    """Raise ParamError (one line) unless `path` can be written: its directory exists, it is
    not a directory, opening it for writing works (a new file is removed again), and for an
    image its extension is one matplotlib saves to. Nothing existing is changed."""
    where = f"{option}: value {shown(path)} is not allowed"
    if image:
        ext = Path(path).suffix.lower().lstrip(".")
        formats = image_formats()
        if ext not in formats:
            raise ParamError([f"{where}; expected a file name ending in one of "
                              + ", ".join("." + f for f in formats)])
    existed = os.path.lexists(path)
    try:
        with open(path, "a"):
            pass
    except OSError as exc:
        raise ParamError([f"{where}; cannot be written ({exc.strerror or exc}); expected a "
                          "writable file in an existing directory"]) from None
    if not existed:
        os.unlink(path)


def check_output_folder(option: str, path: Path) -> None:
    """Raise ParamError (one line) unless files can be written into folder `path`: it is a
    folder, or it does not exist and its nearest existing parent is one, and a file can be
    made there (tried: a probe file, removed at once; the folders are made only when the files
    are written)."""
    where = f"{option}: value {shown(str(path))} is not allowed"
    if path.exists() and not path.is_dir():
        raise ParamError([f"{where}; it exists and is not a folder"])
    parent = path
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise ParamError([f"{where}; {shown(str(parent))} is not a folder"])
    try:
        with tempfile.NamedTemporaryFile(dir=parent):
            pass
    except OSError as exc:
        raise ParamError([f"{where}; {shown(str(parent))} cannot be written "
                          f"({exc.strerror or exc}); expected a writable folder"]) from None


def utc_instant(option: str, text: str, now: datetime) -> datetime:
    """`HH:MM:SS` (today, UTC) or an ISO 8601 time (UTC unless it has an offset) -> an aware
    UTC datetime in (now, now + INSTANT_AHEAD_MAX), whole seconds; else one ParamError line
    naming `option`."""
    bad = (f"{option}: value {shown(text)} is not allowed; expected HH:MM:SS (UTC, today) "
           "or an ISO 8601 time, whole seconds, after now and less than 24 h ahead (now "
           f"{now:%Y-%m-%dT%H:%M:%SZ})")
    try:
        if text.count(":") == 2 and "T" not in text and " " not in text.strip():
            t = datetime.combine(now.date(), datetime.strptime(text, "%H:%M:%S").time())
        else:
            t = datetime.fromisoformat(text.strip().replace("Z", "+00:00"))
    except ValueError:
        raise ParamError([bad]) from None
    t = t.replace(tzinfo=timezone.utc) if t.tzinfo is None else t.astimezone(timezone.utc)
    if t.microsecond or not now < t < now + INSTANT_AHEAD_MAX:
        raise ParamError([bad])
    return t
