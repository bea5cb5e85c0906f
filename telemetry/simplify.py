"""Track simplification for the map (issue 9): a bounded number of points that keeps the shape.

Pure, stdlib only. A track is a time-ordered sequence of (t, lat, lon), t in Unix seconds.

The method is per-bucket selection (the M4 idea of time-series plotting, in two dimensions):
cut the track into equal time buckets and keep, of each bucket, its first and last point and its
northmost, southmost, eastmost and westmost points. The first and last fix of the track and its
four extremes are then always kept (each is the first, last or extreme of its own bucket), turns
show up as bucket extremes, and the work is one pass over the points. The bucket width grows
until the kept points fit ``max_points``, so the bound holds including the kept points.

Reporting gaps (more than ``gap_s`` between two consecutive fixes) are breaks: the answer is a
list of segments, and a segment never joins two kept points with a gap between them. While
there is room, buckets are also cut at gaps, so each segment starts and ends on the real fixes
either side of its gap.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

Point = tuple[float, float, float]  # (t, lat, lon)
Segment = list[Point]

# first, last, north, south, east, west: the most a bucket keeps.
KEPT_PER_BUCKET = 6
# The smallest bound that can hold one bucket's points.
MIN_POINTS = KEPT_PER_BUCKET
# Each retry widens the buckets at least this much, so the loop ends in a few passes.
MIN_GROWTH = 1.25
# A first pass keeping under this share of max_points gets one pass with narrower buckets,
# aimed at max_points / REFILL_MARGIN (a margin, as buckets do not all keep the same count).
UNDERFILLED = 0.7
REFILL_MARGIN = 1.1


def simplify(
    points: Sequence[Point],
    *,
    max_points: int,
    gap_s: float = math.inf,
    gaps: Sequence[int] | None = None,
) -> list[Segment]:
    """At most ``max_points`` of ``points`` as segments split at reporting gaps (see module doc).

    ``points`` must be sorted by time. The breaks are where more than ``gap_s`` passes between
    two consecutive points, or, when the points are only a summary of the fixes (candidates of
    the track overview, where two consecutive points need not be consecutive fixes), exactly
    the ``gaps`` given: indices i with a break between points[i] and points[i + 1], ascending.
    """
    if max_points < MIN_POINTS:
        raise ValueError(f"max_points must be at least {MIN_POINTS}")
    if not points:
        return []
    gaps = list(gaps) if gaps is not None else gap_positions(points, gap_s)
    if len(points) <= max_points:
        keep = list(range(len(points)))
    else:
        keep = _bounded_selection(points, gaps, max_points)
    return _segments(points, keep, gaps)


def gap_positions(points: Sequence[Point], gap_s: float) -> list[int]:
    """Indices i where more than ``gap_s`` passes between points[i] and points[i + 1]."""
    return [i for i in range(len(points) - 1) if points[i + 1][0] - points[i][0] > gap_s]


def _bounded_selection(points: Sequence[Point], gaps: list[int], max_points: int) -> list[int]:
    span = points[-1][0] - points[0][0]
    # Cutting buckets at gaps gives each run between gaps its own buckets: exact segment ends.
    # Only while one bucket per run fits the bound; with more gaps than that, buckets ignore
    # them and the gaps still show as breaks between the kept points either side.
    split_at_gaps = KEPT_PER_BUCKET * (len(gaps) + 1) <= max_points
    runs = _runs(len(points), gaps if split_at_gaps else [])
    buckets = max(1, max_points // KEPT_PER_BUCKET - (len(runs) - 1))
    width = max(span / buckets, 1e-9)
    keep = _select(points, runs, points[0][0], width)
    if len(keep) < max_points * UNDERFILLED:
        # Buckets seldom keep all six (on a straight leg first, last and the extremes
        # coincide): one more pass with buckets sized by the points actually kept per bucket.
        narrower = width * len(keep) / max_points * REFILL_MARGIN
        retry = _select(points, runs, points[0][0], max(narrower, 1e-9))
        if len(retry) <= max_points:
            return retry
    # Terminates: once a bucket is wider than the track, each run is one bucket of at most
    # KEPT_PER_BUCKET points, which fits by the choice of split_at_gaps (and MIN_POINTS).
    while len(keep) > max_points:
        width *= max(MIN_GROWTH, len(keep) / max_points)
        keep = _select(points, runs, points[0][0], width)
    return keep


def _runs(n: int, gaps: list[int]) -> list[tuple[int, int]]:
    """[start, end) index ranges between gaps."""
    runs, start = [], 0
    for g in gaps:
        runs.append((start, g + 1))
        start = g + 1
    runs.append((start, n))
    return runs


def _select(
    points: Sequence[Point], runs: list[tuple[int, int]], t0: float, width: float
) -> list[int]:
    """Indices kept with buckets of ``width`` seconds from ``t0``, never across a run's end.

    One plain loop: measured faster than bisecting to each bucket and taking min/max over
    index ranges (the buckets here hold a handful of points, where per-bucket set-up wins).
    """
    keep: list[int] = []
    for start, end in runs:
        key = None
        first = last = north = south = east = west = start
        n_lat = s_lat = e_lon = w_lon = 0.0
        for i in range(start, end):
            t, lat, lon = points[i]
            k = (t - t0) // width
            if k != key:
                if key is not None:
                    keep.extend(sorted({first, last, north, south, east, west}))
                key = k
                first = last = north = south = east = west = i
                n_lat = s_lat = lat
                e_lon = w_lon = lon
                continue
            last = i
            if lat > n_lat:
                n_lat, north = lat, i
            elif lat < s_lat:
                s_lat, south = lat, i
            if lon > e_lon:
                e_lon, east = lon, i
            elif lon < w_lon:
                w_lon, west = lon, i
        if key is not None:
            keep.extend(sorted({first, last, north, south, east, west}))
    return keep


def _segments(points: Sequence[Point], keep: list[int], gaps: list[int]) -> list[Segment]:
    """Kept points in order, a new segment wherever a gap lies between two kept points."""
    segments: list[Segment] = []
    current: Segment = []
    g = 0
    previous = -1
    for i in keep:
        while g < len(gaps) and gaps[g] < i:
            if gaps[g] >= previous and current:
                segments.append(current)
                current = []
            g += 1
        current.append(points[i])
        previous = i
    if current:
        segments.append(current)
    return segments
