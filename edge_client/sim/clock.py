"""The simulator's clock: one source for its physics, stream rates, start-up delays and
mission protocol timeouts, so a test can run the simulated Rover faster than real time.

The edge client keeps real time; only the vehicle's world runs ``scale`` times faster. At
``scale`` 1 the clock is the host's own, so the simulator behaves exactly as without one.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol


class SimClock(Protocol):
    def monotonic(self) -> float:
        """Seconds on the simulator's own steady clock (time.monotonic's scale)."""
        ...

    def time(self) -> float:
        """The simulator's UTC in Unix seconds (what its GPS would say)."""
        ...


class ScaledClock:
    """The host's clocks sped up ``scale`` times from the moment it is made.

    ``monotonic`` and ``wall`` are the host clocks read (injectable so the scaling itself can
    be checked without waiting)."""

    def __init__(
        self,
        scale: float = 1.0,
        *,
        monotonic: Callable[[], float] = time.monotonic,
        wall: Callable[[], float] = time.time,
    ) -> None:
        if not scale > 0:
            raise ValueError(f"time scale must be positive, not {scale!r}")
        self.scale = scale
        self._monotonic, self._wall = monotonic, wall
        self._t0, self._w0 = monotonic(), wall()

    def monotonic(self) -> float:
        if self.scale == 1:
            return self._monotonic()
        return self._t0 + (self._monotonic() - self._t0) * self.scale

    def time(self) -> float:
        if self.scale == 1:
            return self._wall()
        return self._w0 + (self._monotonic() - self._t0) * self.scale
