"""Alert reads for pages and the API."""

from __future__ import annotations

import datetime as dt
import math
from collections import defaultdict
from collections.abc import Iterable, Mapping
from typing import Any

from django.conf import settings
from django.utils import timezone

from alerts.endurance import HOUR_S, endurance_hours, hourly_means_from_channels
from alerts.evaluator import ENDURANCE_HOURS
from telemetry.models import TrackBucket
from vessels.models import Vessel

# Vessels per query: SQLite's bound-parameter limit.
CHUNK = 500


def fleet_endurance_hours(
    vessel_ids: Iterable[int], *, now: dt.datetime | None = None, empty_v: float | None = None
) -> dict[int, float | None]:
    """Each vessel's battery endurance as the endurance rules judge it (alerts/endurance.py):
    hours to ``empty_v`` (default ALERTS_BATTERY_EMPTY_V), math.inf when the battery is not
    falling day over day, None without two days of reports. One read of the track overview's
    hourly buckets per CHUNK vessels."""
    ids = list(vessel_ids)
    now = now or timezone.now()
    hour = math.floor(now.timestamp() / HOUR_S) * HOUR_S
    empty = settings.ALERTS_BATTERY_EMPTY_V if empty_v is None else empty_v
    rows: dict[int, list[tuple[int, Any]]] = defaultdict(list)
    for at in range(0, len(ids), CHUNK):
        buckets = TrackBucket.objects.filter(
            vessel_id__in=ids[at : at + CHUNK],
            width=HOUR_S,
            start__gte=hour - ENDURANCE_HOURS * HOUR_S,
            start__lt=hour,
        ).values_list("vessel_id", "start", "channels")
        for vessel_id, start, channels in buckets:
            rows[vessel_id].append((start, channels))
    return {
        v: endurance_hours(
            hourly_means_from_channels(rows[v]), empty_v=empty, now_s=now.timestamp()
        )
        for v in ids
    }


def vessel_endurance_hours(
    *, vessel: Vessel, now: dt.datetime | None = None, empty_v: float | None = None
) -> float | None:
    """One vessel's ``fleet_endurance_hours``, for its page."""
    return fleet_endurance_hours([vessel.pk], now=now, empty_v=empty_v)[vessel.pk]


def endurance_text(hours: float | None, empty_v: float | None = None) -> str:
    """The one wording of an endurance figure: the vessel's admin page and the map's panel."""
    empty = settings.ALERTS_BATTERY_EMPTY_V if empty_v is None else empty_v
    if hours is None:
        return "not enough history yet (it needs two days of reports)"
    if math.isinf(hours):
        return "the battery is not falling, day over day"
    return f"{hours:.0f} h to empty ({empty:g} V), day over day"


def endurance_entry(hours: float | None) -> Mapping[str, Any]:
    """An endurance figure as JSON has it (no infinity): hours (null unless falling), text."""
    finite = hours is not None and not math.isinf(hours)
    return {"hours": round(hours, 1) if finite else None, "text": endurance_text(hours)}
