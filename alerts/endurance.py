"""Battery endurance: hours until the battery reaches its empty voltage. Pure, stdlib only.

Why not the slope of the last few hours: a solar-charged vessel (every Wave Glider, a SPAB boat
with panels) charges by day and drains by night. A trend over the morning reads as charging
(infinite endurance), over the evening as a steep fall (hours left); neither is the truth.

The method: **day-over-day differences of hourly means.**

1. Take the battery voltage's mean over each whole clock hour (the track overview's hourly
   buckets hold exactly that: sum and count per channel).
2. For each of the last 24 whole hours ``h`` that has a mean, and whose same hour a day earlier
   (``h - 24``) has one too, take ``(mean[h] - mean[h - 24]) / 24 h``. Any pattern that repeats
   every 24 hours (the sun, a daily duty cycle) is the same at ``h`` and ``h - 24`` and cancels
   exactly, whatever its shape; what is left is the trend.
3. The trend is the mean of those per-hour rates (volts per hour), once at least MIN_PAIRS hours
   have their pair (fewer: no estimate).
4. The level that will reach empty first is the day's trough: the lowest hourly mean of the last
   24 hours (at night, on a solar vessel). Endurance is ``(trough - empty) / -trend``.

The answer is in hours; ``0.0`` when the trough is already at or below empty; ``math.inf`` when
the trend is not falling (the battery holds or gains day over day); ``None`` when there is not
enough history yet (under two days of reports, or too many gaps).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

HOUR_S = 3600
DAY_H = 24
# Hours of the last day that must have a same-hour mean a day earlier for an estimate: a
# quarter of the day, so a vessel that reports only some of the time still gets one, but two
# or three lucky hours do not make a trend.
MIN_PAIRS = 6


def endurance_hours(
    hourly_means: Mapping[int, float], *, empty_v: float, now_s: float
) -> float | None:
    """Hours until the battery's daily trough reaches ``empty_v`` (module docstring).

    ``hourly_means``: hour start (Unix seconds, a multiple of 3600) -> mean voltage over that
    hour. ``now_s``: the time of the estimate; the hour it falls in is not whole yet and is not
    used.
    """
    current = math.floor(now_s / HOUR_S) * HOUR_S
    last_day = [current - HOUR_S * k for k in range(1, DAY_H + 1)]
    rates = []
    for hour in last_day:
        now_v = hourly_means.get(hour)
        before_v = hourly_means.get(hour - DAY_H * HOUR_S)
        if now_v is not None and before_v is not None:
            rates.append((now_v - before_v) / DAY_H)
    if len(rates) < MIN_PAIRS:
        return None
    trend = sum(rates) / len(rates)  # volts per hour
    trough = min(hourly_means[h] for h in last_day if h in hourly_means)
    if trough <= empty_v:
        return 0.0
    if trend >= 0:
        return math.inf
    return (trough - empty_v) / -trend


def hourly_means_from_channels(
    buckets: list[tuple[int, Mapping[str, list[float]]]], key: str = ""
) -> dict[int, float]:
    """Hour start -> mean of ``key`` (battery is ``""``, telemetry.overview.BATTERY) from the
    track overview's hourly buckets, each (start, channels {key: [min, max, sum, count]})."""
    means = {}
    for start, channels in buckets:
        entry = channels.get(key) if channels else None
        if entry and entry[3]:
            means[start] = entry[2] / entry[3]
    return means
