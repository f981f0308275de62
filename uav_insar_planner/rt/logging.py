"""rclpy-style logging: `[INFO] [1700000000.123456789] [node_name]: message` on stderr."""
from __future__ import annotations

import enum
import sys
import threading
import time


class LoggingSeverity(enum.IntEnum):
    UNSET = 0
    DEBUG = 10
    INFO = 20
    WARN = 30
    ERROR = 40
    FATAL = 50


_LOCK = threading.Lock()
_LEVELS: dict[str, LoggingSeverity] = {}
_default_level = LoggingSeverity.INFO


def set_default_level(level: LoggingSeverity) -> None:
    """Level for loggers without their own (`--log-level LEVEL`)."""
    global _default_level
    _default_level = LoggingSeverity(level)


def parse_severity(text: str) -> LoggingSeverity:
    """'debug' / 'INFO' / 'warn' ... -> LoggingSeverity; ValueError otherwise."""
    name = text.strip().upper()
    name = "WARN" if name == "WARNING" else name
    if name not in LoggingSeverity.__members__ or name == "UNSET":
        raise ValueError(f"unknown log level {text!r}")
    return LoggingSeverity[name]


class RcutilsLogger:
    """A named logger with rclpy's methods (debug/info/warn/warning/error/fatal)."""

    def __init__(self, name: str = "") -> None:
        self.name = name
        self._once: set[tuple] = set()
        self._last: dict[tuple, float] = {}

    def get_child(self, name: str) -> RcutilsLogger:
        return RcutilsLogger(f"{self.name}.{name}" if self.name else name)

    def set_level(self, level: LoggingSeverity) -> None:
        _LEVELS[self.name] = LoggingSeverity(level)

    def get_effective_level(self) -> LoggingSeverity:
        return _LEVELS.get(self.name, _default_level)

    def is_enabled_for(self, severity: LoggingSeverity) -> bool:
        return severity >= self.get_effective_level()

    def log(self, message: str, severity: LoggingSeverity, *, once: bool = False,
            throttle_duration_sec: float | None = None, skip_first: bool = False,
            **_ignored: object) -> bool:
        """Write one line if enabled; returns whether it was written (as rclpy)."""
        if not self.is_enabled_for(severity):
            return False
        caller = sys._getframe(2)
        site = (caller.f_code.co_filename, caller.f_lineno)
        if once or skip_first:
            first = site not in self._once
            self._once.add(site)
            if (once and not first) or (skip_first and first):
                return False
        if throttle_duration_sec:
            now = time.monotonic()
            if now - self._last.get(site, -1e18) < throttle_duration_sec:
                return False
            self._last[site] = now
        stamp = time.time_ns()
        line = (f"[{severity.name}] [{stamp // 1_000_000_000}.{stamp % 1_000_000_000:09d}] "
                f"[{self.name}]: {message}\n")
        with _LOCK:
            sys.stderr.write(line)
            sys.stderr.flush()
        return True

    def debug(self, message: str, **kw: object) -> bool:
        return self.log(message, LoggingSeverity.DEBUG, **kw)

    def info(self, message: str, **kw: object) -> bool:
        return self.log(message, LoggingSeverity.INFO, **kw)

    def warning(self, message: str, **kw: object) -> bool:
        return self.log(message, LoggingSeverity.WARN, **kw)

    warn = warning

    def error(self, message: str, **kw: object) -> bool:
        return self.log(message, LoggingSeverity.ERROR, **kw)

    def fatal(self, message: str, **kw: object) -> bool:
        return self.log(message, LoggingSeverity.FATAL, **kw)


def get_logger(name: str) -> RcutilsLogger:
    """rclpy.logging.get_logger."""
    return RcutilsLogger(name)
