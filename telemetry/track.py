"""The map's reads (issue 9): a vessel's track simplified, and its plot series, for a range.

Both read a *cover* of the range (telemetry/overview.py): whole overview buckets in the middle,
finer ones toward the ends, raw fixes for the ragged minutes; so a month costs ~1,000 rows, not
a million fixes. A short range (few fixes) is read from the fixes themselves. Reads never write:
minutes marked out of date (TrackDirty, until `rebuild_track_overview --loop` rebuilds them) are
read from their fixes, and no bucket over them is used, so no answer lags its fixes.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from telemetry import sql
from telemetry.models import Fix
from telemetry.overview import BATTERY, RAW, WIDTHS, Summary, cover, finest_level_within
from telemetry.series import Downsampler, bucket_width
from telemetry.simplify import Point, Segment, simplify
from vessels.models import OVERDUE_PERIODS, Vessel

# A silence as long as the one that makes a vessel overdue is a break in its track.
GAP_PERIODS = OVERDUE_PERIODS
# The track reads the finest overview width with at most this many rows per point asked
# for: each row gives 2-8 candidates, so the simplification has a few times max_points.
TRACK_ROW_BUDGET_PER_POINT = 0.5
# A range holding at most this many fixes is simplified from the fixes themselves.
TRACK_RAW_FIXES = 5000
# A plot range up to this long is bucketed from the raw fixes, to the second; longer ones
# use buckets of at least the overview's finest width.
SERIES_RAW_SPAN_S = 3600


@dataclass
class Track:
    fixes: int
    gap_s: float
    segments: list[Segment]

    @property
    def points(self) -> int:
        return sum(len(s) for s in self.segments)


def gap_seconds(vessel: Vessel) -> float:
    return float(vessel.telemetry_period_s * GAP_PERIODS)


def track(*, vessel: Vessel, start: dt.datetime, end: dt.datetime, max_points: int) -> Track:
    """The vessel's track in [start, end): at most ``max_points`` points in segments."""
    lo, hi = start.timestamp(), end.timestamp()
    gap_s = gap_seconds(vessel)
    level = finest_level_within(lo, hi, int(max_points * TRACK_ROW_BUDGET_PER_POINT))
    dirty = sql.dirty_minutes(vessel.pk, lo, hi)
    points, gaps, count = _candidates(vessel.pk, lo, hi, level, gap_s, dirty)
    if count <= TRACK_RAW_FIXES and len(points) < count:
        points, gaps, count = _candidates(vessel.pk, lo, hi, -1, gap_s)
    return Track(count, gap_s, simplify(points, max_points=max_points, gaps=gaps))


def sketch(*, vessel: Vessel, start: dt.datetime, end: dt.datetime, max_points: int) -> Track:
    """The vessel's track in [start, end) from the overview's buckets alone (raw fixes only
    for the minutes not rebuilt yet): the fleet map's trails want the shape, a few points a
    minute, not the turns between them; ``track`` reads every fix of a short range instead,
    ten times the work for an hour of 1 Hz fixes."""
    lo, hi = start.timestamp(), end.timestamp()
    gap_s = gap_seconds(vessel)
    level = finest_level_within(lo, hi, int(max_points * TRACK_ROW_BUDGET_PER_POINT))
    dirty = sql.dirty_minutes(vessel.pk, lo, hi)
    points, gaps, count = _candidates(vessel.pk, lo, hi, level, gap_s, dirty)
    return Track(count, gap_s, simplify(points, max_points=max_points, gaps=gaps))


def latest_stretch(
    *, vessel: Vessel, max_span: dt.timedelta, max_points: int
) -> tuple[dt.datetime, dt.datetime] | None:
    """(first, last) fix time of the vessel's last run of reports, at most ``max_span`` long
    and ending at its newest fix; None when it has no fixes.

    The run is the last segment of the track over ``max_span`` before the newest fix, read as
    the map reads it (the overview, broken at silences longer than ``gap_seconds``): with the
    map's ``max_points``, the run starts on its real first fix.
    """
    newest = (
        Fix.objects.filter(vessel=vessel)
        .order_by("-recorded_at")
        .values_list("recorded_at", flat=True)
        .first()
    )
    if newest is None:
        return None
    end = newest + dt.timedelta(seconds=1)  # the range is half-open: [start, end)
    result = track(vessel=vessel, start=end - max_span, end=end, max_points=max_points)
    if not result.segments:
        return newest, newest
    return sql.from_epoch(result.segments[-1][0][0]), newest


def _candidates(
    vessel_id: int, lo: float, hi: float, level: int, gap_s: float, dirty: Sequence[int] = ()
) -> tuple[list[Point], list[int], int]:
    """(points, break indices, fixes counted) over the cover of [lo, hi) at ``level``.

    Two consecutive candidates are consecutive fixes when they are the last and first of
    neighbouring buckets (or raw fixes), and the two sides of a bucket's longest silence; only
    there can a break be known, and only there is one put.
    """
    points: list[Point] = []
    gaps: list[int] = []
    count = 0
    for width, a, b in cover(lo, hi, level, dirty):
        if width == RAW:
            for point in sql.raw_points(vessel_id, a, b):
                if points and point[0] - points[-1][0] > gap_s:
                    gaps.append(len(points) - 1)
                points.append(point)
                count += 1
            continue
        for bucket in sql.buckets(vessel_id, width, a, b, channels=False):
            kept = bucket.candidates()
            if points and kept[0][0] - points[-1][0] > gap_s:
                gaps.append(len(points) - 1)
            if bucket.gap and bucket.gap_s > gap_s:
                gaps.append(len(points) + kept.index(bucket.gap[0]))
            points += kept
            count += bucket.count
    return points, gaps, count


@dataclass
class Series:
    bucket_s: int
    starts: list[int]
    # key ("" = battery_v) -> the channel's min, max and mean per bucket
    channels: dict[str, dict[str, list[Any]]]


def series(*, vessel: Vessel, start: dt.datetime, end: dt.datetime, max_buckets: int) -> Series:
    """Battery and every reading in [start, end), in at most ``max_buckets`` min/max buckets."""
    lo, hi = start.timestamp(), end.timestamp()
    width = bucket_width(lo, hi, max_buckets)
    if hi - lo > SERIES_RAW_SPAN_S:
        width = max(width, WIDTHS[0])
    # The coarsest overview width that divides the bucket: each of its rows lies in one bucket.
    level = max((i for i, w in enumerate(WIDTHS) if width % w == 0), default=-1)
    sampler = Downsampler(lo, hi, width)
    dirty = sql.dirty_minutes(vessel.pk, lo, hi)
    for piece_width, a, b in cover(lo, hi, level, dirty):
        if piece_width == RAW:
            for t, _lat, _lon, battery, readings in sql.raw_fixes(vessel.pk, a, b):
                if battery is not None:
                    sampler.add(BATTERY, t, battery)
                for key, value in (readings or {}).items():
                    if isinstance(value, int | float) and not isinstance(value, bool):
                        sampler.add(key, t, value)
            continue
        for bucket in sql.buckets(vessel.pk, piece_width, a, b, points=False):
            _add_bucket(sampler, bucket)
    return Series(
        width,
        sampler.starts,
        {
            key: {"min": c.min, "max": c.max, "mean": c.mean}
            for key, c in sampler.channels.items()  # type: ignore[misc]
        },
    )


def _add_bucket(sampler: Downsampler, bucket: Summary) -> None:
    for key, (low, high, total, count) in bucket.channels.items():
        sampler.add_aggregate(key, bucket.start, low, high, total, int(count))
