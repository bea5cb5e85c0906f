"""Min/max downsampling of time series for the plots (issue 9). Pure, stdlib only.

A range is cut into at most N buckets of a "nice" width (1 s … 1 day and whole days), aligned
to multiples of that width since the Unix epoch, so bucket starts are stable as the range moves
and coarser pre-aggregated data (per-minute, per-hour) falls whole into one bucket. Each bucket
keeps the min, the max, the sum and the count of what fell in it, so a one-sample spike is still
the bucket's max when zoomed out; the mean is sum / count. A bucket with no data is None.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Iterable
from dataclasses import dataclass, field
from typing import Any

# Bucket widths in seconds, smallest first; past the last, whole multiples of a day.
NICE_WIDTHS = (1, 2, 5, 10, 15, 30, 60, 120, 300, 600, 900, 1800, 3600, 7200, 10800, 21600,
               43200, 86400)  # fmt: skip
DAY_S = 86400


def bucket_count(start: float, end: float, width: int) -> int:
    """How many epoch-aligned buckets of ``width`` seconds [start, end) touches."""
    if end <= start:
        return 0
    return math.ceil(end / width) - math.floor(start / width)


def bucket_width(start: float, end: float, max_buckets: int) -> int:
    """The smallest nice width that cuts [start, end) into at most ``max_buckets`` buckets."""
    if max_buckets < 1:
        raise ValueError("max_buckets must be at least 1")
    for width in NICE_WIDTHS:
        if bucket_count(start, end, width) <= max_buckets:
            return width
    days = 1
    while bucket_count(start, end, days * DAY_S) > max_buckets:
        days *= 2
    return days * DAY_S


@dataclass
class Channel:
    """One series' buckets: parallel lists, None where a bucket holds nothing."""

    min: list[float | None]
    max: list[float | None]
    sum: list[float]
    count: list[int]

    @property
    def mean(self) -> list[float | None]:
        return [s / c if c else None for s, c in zip(self.sum, self.count, strict=True)]


@dataclass
class Downsampler:
    """Buckets of ``width`` seconds over [start, end); feed samples or aggregates, any order."""

    start: float
    end: float
    width: int
    channels: dict[Hashable, Channel] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.first = math.floor(self.start / self.width)
        self.size = bucket_count(self.start, self.end, self.width)

    @property
    def starts(self) -> list[int]:
        """Each bucket's start, Unix seconds."""
        return [(self.first + i) * self.width for i in range(self.size)]

    def add(self, key: Hashable, t: float, value: float) -> None:
        self.add_aggregate(key, t, value, value, value, 1)

    def add_aggregate(
        self, key: Hashable, t: float, low: float, high: float, total: float, count: int
    ) -> None:
        """Samples summarised elsewhere (min, max, sum, count) that all lie in t's bucket."""
        if not self.start <= t < self.end or count <= 0:
            return
        channel = self.channels.get(key)
        if channel is None:
            channel = self.channels[key] = Channel(
                [None] * self.size, [None] * self.size, [0.0] * self.size, [0] * self.size
            )
        i = math.floor(t / self.width) - self.first
        old_low, old_high = channel.min[i], channel.max[i]
        channel.min[i] = low if old_low is None or low < old_low else old_low
        channel.max[i] = high if old_high is None or high > old_high else old_high
        channel.sum[i] += total
        channel.count[i] += count


def downsample(
    samples: Iterable[tuple[float, float]], *, start: float, end: float, max_buckets: int
) -> dict[str, Any]:
    """One series of (t, value) as {"bucket_s", "t", "min", "max", "mean", "count"}."""
    sampler = Downsampler(start, end, bucket_width(start, end, max_buckets))
    for t, value in samples:
        sampler.add("", t, value)
    channel = sampler.channels.get("") or Channel(
        [None] * sampler.size, [None] * sampler.size, [0.0] * sampler.size, [0] * sampler.size
    )
    return {
        "bucket_s": sampler.width,
        "t": sampler.starts,
        "min": channel.min,
        "max": channel.max,
        "mean": channel.mean,
        "count": channel.count,
    }
