"""The switch's control channel: one command per UNIX datagram, one reply datagram each.

    set PORT [loss=P] [delay=S] [jitter=S] [dist=uniform|normal] [dir=in|out|both]
        change the named fields of PORT's impairment (the others keep their values);
        "in" is what PORT's namespace sends, "out" what it receives; dir defaults to both
    cut PORT [dir=...]       drop every frame (the link is gone)
    restore PORT [dir=...]   lift the cut (loss and delay stay as set)
    clear PORT [dir=...]     a perfect link again (no loss, no delay, no cut)
    stats                    JSON: per port rx (frames read from it), rx_multicast (those of
                             them to an IPv4 multicast group, e.g. DDS SPDP), tx (written to it),
                             dropped_in, dropped_out, write_errors, and "in" and "out" (the
                             LinkSpec of each direction); and queued (delayed frames)

Replies: "ok", a JSON line for stats, or "error: ..." (one line naming the word, the value
and what is allowed); a refused command changes nothing.
"""
from __future__ import annotations

import os
import socket
from collections.abc import Sequence
from dataclasses import dataclass, field

from uav_insar_sim.netlab.impair import DISTRIBUTIONS

VERBS = ("set", "cut", "restore", "clear", "stats")
DIRECTIONS = {"in": ("in",), "out": ("out",), "both": ("in", "out")}
NUMBER_KEYS = ("loss", "delay", "jitter")
MAX_COMMAND_BYTES = 1024
SHOWN_CHARS = 40


@dataclass
class Command:
    """A parsed control command; `fields` are LinkSpec fields (set) for `directions`."""

    verb: str
    port: str = ""
    directions: tuple[str, ...] = ("in", "out")
    fields: dict[str, object] = field(default_factory=dict)


def _shown(text: str) -> str:
    text = repr(text)
    return text if len(text) <= SHOWN_CHARS else text[:SHOWN_CHARS - 3] + "..."


def _number(key: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if value != value or value in (float("inf"), float("-inf")):  # NaN or infinite
        raise ValueError(f"{key}={_shown(text)} not allowed: a finite number "
                         f"({'a probability' if key == 'loss' else 'seconds'})")
    return value


def parse(line: str, ports: Sequence[str]) -> Command:
    """The command in `line`; ValueError (one line) if it is not one for these `ports`.
    Field ranges are checked where they are applied (LinkSpec)."""
    words = line.split()
    if not words or words[0] not in VERBS:
        raise ValueError(f"command {_shown(words[0] if words else line)} not allowed: one "
                         f"of {', '.join(VERBS)}")
    verb, args = words[0], words[1:]
    if verb == "stats":
        if args:
            raise ValueError(f"stats argument {_shown(args[0])} not allowed: stats takes none")
        return Command(verb)
    if not args:
        raise ValueError(f"{verb} needs a port: one of {', '.join(ports)}")
    if args[0] not in ports:
        raise ValueError(f"port {_shown(args[0])} not allowed: one of {', '.join(ports)}")
    cmd = Command(verb, args[0])
    allowed = ("dir",) + ((*NUMBER_KEYS, "dist") if verb == "set" else ())
    for arg in args[1:]:
        key, eq, value = arg.partition("=")
        if not eq or key not in allowed:
            raise ValueError(f"{verb} argument {_shown(arg)} not allowed: "
                             f"{' '.join(k + '=...' for k in allowed)}")
        if key == "dir":
            if value not in DIRECTIONS:
                raise ValueError(f"dir={_shown(value)} not allowed: one of in, out, both")
            cmd.directions = DIRECTIONS[value]
        elif key == "dist":
            if value not in DISTRIBUTIONS:
                raise ValueError(f"dist={_shown(value)} not allowed: one of "
                                 f"{', '.join(DISTRIBUTIONS)}")
            cmd.fields[key] = value
        else:
            cmd.fields[key] = _number(key, value)
    return cmd


def send(path: str, command: str, timeout: float = 2.0) -> str:
    """Send `command` to the switch listening on `path`; its reply. TimeoutError if none."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sock:
        sock.bind("")  # Linux autobind: an abstract address the switch can answer
        sock.settimeout(timeout)
        sock.sendto(command.encode(), os.fspath(path))
        return sock.recv(65536).decode()
