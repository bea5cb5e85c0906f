"""The track overview's arithmetic (issue 9 "Speed"). Pure, stdlib only.

A month of 1 Hz fixes cannot be read in the 50 ms a map allows, so each vessel's fixes are also
summarised per time bucket at a few widths (a minute, ten minutes, an hour): per bucket its
count; its first, last, northmost, southmost, eastmost and westmost fix; the two fixes either
side of its longest silence; and per channel (battery and each reading) min, max, sum and count.
A bucket is rebuilt from the raw fixes (the finest width) or from the buckets of the next finer
width (coarser ones); every field merges exactly, so a coarse bucket equals one built from raw.

A time range is then read as a *cover*: the coarsest whole buckets inside it, finer buckets at
its ragged ends, raw fixes for the parts shorter than a minute. Every fix in the range is counted
exactly once and the range's first, last and extreme fixes are among the candidates. Minutes
whose buckets are not rebuilt yet are read from their fixes too, so a read never writes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from telemetry.simplify import Point

# Overview bucket widths in seconds, finest first; each divides the next.
WIDTHS = (60, 600, 3600)
RAW = 0  # the "width" of raw fixes in a cover
# Battery's key among the channels: reading names are 1-50 characters, so "" never clashes.
BATTERY = ""

# (t, lat, lon, battery_v, readings) of one raw fix, t in Unix seconds.
RawFix = tuple[float, float, float, float | None, dict[str, Any] | None]


@dataclass(slots=True)
class Summary:
    """One overview bucket (or one raw fix, as a bucket of one)."""

    start: int
    count: int
    first: Point
    last: Point
    north: Point
    south: Point
    east: Point
    west: Point
    # The fixes either side of the longest silence inside the bucket (None: fewer than 2 fixes).
    gap: tuple[Point, Point] | None = None
    # key -> [min, max, sum, count]
    channels: dict[str, list[float]] = field(default_factory=dict)

    @property
    def gap_s(self) -> float:
        return self.gap[1][0] - self.gap[0][0] if self.gap else 0.0

    def candidates(self) -> list[Point]:
        """The bucket's distinct kept points, in time order (what a track may draw)."""
        points = [self.first, self.last, self.north, self.south, self.east, self.west]
        if self.gap:
            points += self.gap
        return sorted(set(points))


def bucket_start(t: float, width: int) -> int:
    return math.floor(t / width) * width


def _channel_add(channels: dict[str, list[float]], key: str, value: Any) -> None:
    if value is None or isinstance(value, bool) or not isinstance(value, int | float):
        return
    entry = channels.get(key)
    if entry is None:
        channels[key] = [value, value, value, 1]
        return
    if value < entry[0]:
        entry[0] = value
    if value > entry[1]:
        entry[1] = value
    entry[2] += value
    entry[3] += 1


def summarize(start: int, fixes: Sequence[RawFix]) -> Summary:
    """A bucket from its raw fixes, sorted by time (at least one)."""
    t, lat, lon, _, _ = fixes[0]
    point = (t, lat, lon)
    s = Summary(start, 0, point, point, point, point, point, point)
    previous: Point | None = None
    longest = -1.0
    for t, lat, lon, battery, readings in fixes:
        point = (t, lat, lon)
        s.count += 1
        s.last = point
        if lat > s.north[1]:
            s.north = point
        if lat < s.south[1]:
            s.south = point
        if lon > s.east[2]:
            s.east = point
        if lon < s.west[2]:
            s.west = point
        if previous is not None and t - previous[0] > longest:
            longest, s.gap = t - previous[0], (previous, point)
        previous = point
        _channel_add(s.channels, BATTERY, battery)
        for key, value in (readings or {}).items():
            _channel_add(s.channels, key, value)
    return s


def merge(start: int, parts: Sequence[Summary]) -> Summary:
    """One bucket from finer ones (sorted by time, at least one), exactly as if from raw."""
    head = parts[0]
    s = Summary(start, 0, head.first, head.last, head.north, head.south, head.east, head.west)
    previous: Summary | None = None
    for part in parts:
        s.count += part.count
        s.last = part.last
        if part.north[1] > s.north[1]:
            s.north = part.north
        if part.south[1] < s.south[1]:
            s.south = part.south
        if part.east[2] > s.east[2]:
            s.east = part.east
        if part.west[2] < s.west[2]:
            s.west = part.west
        if part.gap and part.gap_s > s.gap_s:
            s.gap = part.gap
        if previous is not None and part.first[0] - previous.last[0] > s.gap_s:
            s.gap = (previous.last, part.first)
        previous = part
        for key, (low, high, total, count) in part.channels.items():
            entry = s.channels.get(key)
            if entry is None:
                s.channels[key] = [low, high, total, count]
            else:
                entry[0] = min(entry[0], low)
                entry[1] = max(entry[1], high)
                entry[2] += total
                entry[3] += count
    return s


def group_by_bucket(items: Iterable[Any], width: int, time_of: Any) -> dict[int, list[Any]]:
    """Items (in time order) grouped by the start of their bucket of ``width`` seconds."""
    groups: dict[int, list[Any]] = {}
    for item in items:
        groups.setdefault(bucket_start(time_of(item), width), []).append(item)
    return groups


def cover(
    start: float, end: float, level: int, dirty: Sequence[int] = ()
) -> list[tuple[int, float, float]]:
    """[start, end) as (width, lo, hi) pieces in time order: whole buckets of WIDTHS[level]
    in the middle, finer widths toward the ends, RAW for what no whole minute covers.

    ``dirty``: sorted starts of minutes whose buckets are out of date (not yet rebuilt). They
    are RAW pieces, and no bucket piece holds one: a coarse bucket over a dirty minute is as
    stale as the minute's own, so the clean stretches between them are covered on their own.
    Adjacent RAW pieces are joined (one read of the fixes each)."""
    pieces: list[tuple[int, float, float]] = []
    at = start
    for lo, hi in _minute_runs(dirty):
        lo, hi = max(lo, at), min(hi, end)
        if lo >= hi:
            continue
        pieces += _cover(at, lo, level)
        pieces.append((RAW, lo, hi))
        at = hi
    pieces += _cover(at, end, level)
    joined: list[tuple[int, float, float]] = []
    for piece in pieces:
        if joined and piece[0] == RAW == joined[-1][0] and joined[-1][2] == piece[1]:
            joined[-1] = (RAW, joined[-1][1], piece[2])
        else:
            joined.append(piece)
    return joined


def _minute_runs(minutes: Sequence[int]) -> list[tuple[int, int]]:
    """Sorted minute starts as [lo, hi) runs of consecutive minutes."""
    runs: list[tuple[int, int]] = []
    for m in minutes:
        if runs and runs[-1][1] == m:
            runs[-1] = (runs[-1][0], m + WIDTHS[0])
        else:
            runs.append((m, m + WIDTHS[0]))
    return runs


def _cover(start: float, end: float, level: int) -> list[tuple[int, float, float]]:
    if end <= start:
        return []
    if level < 0:
        return [(RAW, start, end)]
    width = WIDTHS[level]
    lo, hi = math.ceil(start / width) * width, math.floor(end / width) * width
    # Division rounds: never let a bucket stick out of the range.
    lo += width if lo < start else 0
    hi -= width if hi > end else 0
    if lo >= hi:
        return _cover(start, end, level - 1)
    return [
        *_cover(start, lo, level - 1),
        (width, lo, hi),
        *_cover(hi, end, level - 1),
    ]


def finest_level_within(start: float, end: float, max_buckets: int) -> int:
    """The finest level whose buckets over [start, end) number at most ``max_buckets``; the
    coarsest when none does."""
    for level, width in enumerate(WIDTHS):
        if (end - start) / width <= max_buckets:
            return level
    return len(WIDTHS) - 1
