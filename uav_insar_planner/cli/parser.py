"""The one argument parser of every command of the suite: errors are one line, exit 2.

argparse quotes what it was given in its messages; a line is cut to ERROR_LINE_MAX_CHARS so a
100 kB argument cannot flood the terminal.
"""
from __future__ import annotations

import argparse

from uav_insar_planner.exit_codes import EXIT_BAD_INPUT

ERROR_LINE_MAX_CHARS = 300


def one_line(text: str, limit: int = ERROR_LINE_MAX_CHARS) -> str:
    """`text` on one line (whitespace runs become one space), cut to `limit` characters."""
    text = " ".join(text.split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line `PROG: error: ...` and exit code 2."""

    def error(self, message: str) -> None:
        self.exit(EXIT_BAD_INPUT, one_line(f"{self.prog}: error: {message}") + "\n")
