"""Exponential backoff, the one rule for every retry loop on both sides: the boat's transport
retries, its outage pause, its autopilot reconnects and mode requests, the bridge's modem
reconnects. Pure: the callers keep their own clocks and sleeps."""

from __future__ import annotations

import math


def doubled(delay: float, *, cap: float = math.inf) -> float:
    """The wait after ``delay`` has not been enough: twice it, at most ``cap``."""
    return min(delay * 2, cap)


# Enough doublings to reach any cap from any first wait a caller uses (2**64 ≈ 1.8e19), where
# the waits must go on doubling until the cap; the float cannot overflow.
UNTIL_THE_CAP = 64


def after_failures(first: float, failures: int, *, cap: float, max_doublings: int = 6) -> float:
    """The wait after ``failures`` failures in a row: ``first`` doubled per failure (at most
    ``max_doublings`` times, so a long outage cannot overflow the float), at most ``cap``."""
    return min(cap, first * 2 ** min(failures, max_doublings))
