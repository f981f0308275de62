"""What one direction of one switch port does to a frame: lose it with probability `loss`,
drop everything while `cut`, else delay it by `delay` +- `jitter` seconds.

Jitter is uniform on [delay - jitter, delay + jitter] or Gaussian (sigma = jitter) clipped to
[0, 2 delay]; jitter <= delay keeps every delay >= 0 and the mean at `delay` (the clip is
symmetric). Frames are not kept in order: a frame may overtake one delayed longer, as with
netem's jitter. Each direction draws from its own RNG, seeded from the switch seed and the
port and direction names, so a run with the same seed and the same frames decides the same.
"""
from __future__ import annotations

import random
from dataclasses import dataclass, replace

DISTRIBUTIONS = ("uniform", "normal")
MAX_DELAY_S = 10.0  # longer than any radio link; a typo of ms for s is refused


@dataclass(frozen=True)
class LinkSpec:
    """The impairment of one direction; SI units (probability, seconds)."""

    loss: float = 0.0
    delay: float = 0.0
    jitter: float = 0.0
    dist: str = "uniform"
    cut: bool = False

    def __post_init__(self) -> None:
        if not 0.0 <= self.loss <= 1.0:
            raise ValueError(f"loss={self.loss!r} not allowed: a probability 0..1")
        if not 0.0 <= self.delay <= MAX_DELAY_S:
            raise ValueError(f"delay={self.delay!r} not allowed: 0..{MAX_DELAY_S} s")
        if not 0.0 <= self.jitter <= self.delay:
            raise ValueError(f"jitter={self.jitter!r} not allowed: 0..delay "
                             f"({self.delay!r} s)")
        if self.dist not in DISTRIBUTIONS:
            raise ValueError(f"dist={self.dist!r} not allowed: one of "
                             f"{', '.join(DISTRIBUTIONS)}")

    def updated(self, **fields: object) -> LinkSpec:
        """A copy with `fields` replaced, validated as a whole (ValueError, one line)."""
        return replace(self, **fields)


class Direction:
    """One direction ("in": from the port's namespace, "out": to it) of one port."""

    def __init__(self, seed: int, port: str, direction: str) -> None:
        self.spec = LinkSpec()
        # A str seed is hashed with SHA-512 by random.Random: stable across runs and hosts.
        self._rng = random.Random(f"{seed}/{port}/{direction}")

    def fate(self) -> float | None:
        """None if this frame is dropped, else its delay [s]."""
        spec = self.spec
        if spec.cut or (spec.loss and self._rng.random() < spec.loss):
            return None
        if not spec.jitter:
            return spec.delay
        if spec.dist == "uniform":
            return self._rng.uniform(spec.delay - spec.jitter, spec.delay + spec.jitter)
        return min(max(self._rng.gauss(spec.delay, spec.jitter), 0.0), 2.0 * spec.delay)
