"""Retention's arithmetic (issue 19 item 6): which old fixes thinning deletes. Pure, stdlib only.

A vessel's fixes older than the retention are cut into intervals of ``interval_s`` seconds,
aligned on Unix time (an hour's intervals start on the hour, UTC), and of each interval's fixes
only the first and the last are kept, and every fix kept for its own sake (an alert points at it,
it arrived too recently to thin: telemetry/retention.py decides). The fixes come as a stream in
time order, read in chunks: a fix is known to be neither its interval's first nor its last only
once a later fix of the same interval has been read, so each chunk's answer is final and the
stream can stop at any chunk and start again at its open interval.

Thinning twice changes nothing: a thinned interval's fixes are its first, its last and the
kept ones, and thinning keeps exactly those.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

# One fix of the stream: (id, Unix seconds, kept for its own sake).
Row = tuple[int, float, bool]


def interval_start(t: float, interval_s: int) -> int:
    """The start of the interval holding Unix time ``t``."""
    return math.floor(t / interval_s) * interval_s


@dataclass(slots=True)
class Thinner:
    """One vessel's fixes, fed in time order (in any chunks); ``feed`` answers which to delete.

    ``open_start``: the start of the interval the last fix fed belongs to (None before the first
    fix). Everything before it is decided; a stream resumed there decides the same.
    """

    interval_s: int
    open_start: int | None = None
    # The latest fix of the open interval that is neither its first nor kept: deleted as soon as
    # a later fix of the interval shows it is not the last either.
    pending: int | None = None

    def feed(self, rows: Iterable[Row]) -> list[int]:
        """The ids among ``rows`` (and the pending fix of earlier rows) to delete."""
        doomed: list[int] = []
        for fix_id, t, kept in rows:
            start = interval_start(t, self.interval_s)
            if start != self.open_start:
                # A new interval: the pending fix was the last of its own, and this is the first.
                self.open_start, self.pending = start, None
                continue
            if self.pending is not None:
                doomed.append(self.pending)
            self.pending = None if kept else fix_id
        return doomed


def thin(rows: Iterable[Row], interval_s: int) -> list[int]:
    """The ids to delete from a whole stream (the rows of whole intervals, in time order)."""
    return Thinner(interval_s).feed(rows)
