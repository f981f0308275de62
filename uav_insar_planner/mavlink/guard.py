"""Where values cross the MAVLink boundary: representable going out, finite coming in.

MAVLink float fields are IEEE float32: a finite Python float above FLOAT32_MAX (3.4e38), such
as 1e39, makes pymavlink's struct.pack raise OverflowError, and NaN / Inf pack but mean
nothing to an autopilot. Integer fields must be integers inside their C type. `fits_float32`
and `fits_int` say whether a value may go out; what does not is dropped, never sent.

`DropLog` counts what was dropped per kind and says when a kind deserves a log line: its first
drop, then at most once per `period_s`, with the count since the last line, so a flood of bad
input costs one line per kind every few seconds. It is the one drop log of the suite: the
bridge, the simulated vehicle, the agent and the ROS message decoders (ros/plan_gate.py,
ros/claims.py, ros/start_msgs.py) all count with it.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterable

#: The largest finite IEEE-754 single-precision value.
FLOAT32_MAX = 3.4028234663852886e38
DROP_LOG_PERIOD_S = 10.0


def fits_float32(values: Iterable[float]) -> bool:
    """True when every value is finite and packs as a finite float32 (|v| <= FLOAT32_MAX)."""
    for v in values:
        try:
            f = float(v)
        except (TypeError, ValueError, OverflowError):
            return False
        if not math.isfinite(f) or abs(f) > FLOAT32_MAX:
            return False
    return True


def finite(values: Iterable[float]) -> bool:
    """True when every value is a finite number (received float32 fields may be NaN / Inf)."""
    try:
        return all(math.isfinite(float(v)) for v in values)
    except (TypeError, ValueError, OverflowError):
        return False


def fits_int(value: object, low: int, high: int) -> bool:
    """True for an int (not a bool) in [low, high]."""
    return isinstance(value, int) and not isinstance(value, bool) and low <= value <= high


class DropLog:
    """Drops per kind, and when to say so (see the module doc). Not thread-safe."""

    def __init__(self, period_s: float = DROP_LOG_PERIOD_S,
                 clock: Callable[[], float] = time.monotonic):
        self.period_s = period_s
        self._clock = clock
        self.counts: dict[str, int] = {}
        self._said: dict[str, tuple[float, int]] = {}  # kind -> (when, count then)

    @property
    def total(self) -> int:
        """Drops of every kind."""
        return sum(self.counts.values())

    def drop(self, kind: str, detail: str) -> str | None:
        """Count one drop of `kind`; return the line to log now, or None (rate-limited)."""
        n = self.counts.get(kind, 0) + 1
        self.counts[kind] = n
        now = self._clock()
        last = self._said.get(kind)
        if last is not None and now - last[0] < self.period_s:
            return None
        since = n - (last[1] if last is not None else 0)
        self._said[kind] = (now, n)
        more = f" ({since} since the last report, {n} in all)" if last is not None else ""
        return f"dropped {kind}: {detail[:160]}{more}"
