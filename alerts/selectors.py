"""Alert reads for pages and the API."""

from __future__ import annotations

import datetime as dt
import math

from django.conf import settings
from django.utils import timezone

from alerts.endurance import HOUR_S, endurance_hours, hourly_means_from_channels
from alerts.evaluator import ENDURANCE_HOURS
from telemetry.models import TrackBucket
from vessels.models import Vessel


def vessel_endurance_hours(
    *, vessel: Vessel, now: dt.datetime | None = None, empty_v: float | None = None
) -> float | None:
    """The vessel's battery endurance for its panel, as the endurance rules judge it
    (alerts/endurance.py): hours to ``empty_v`` (default ALERTS_BATTERY_EMPTY_V), math.inf
    when the battery is not falling day over day, None without two days of reports."""
    now = now or timezone.now()
    hour = math.floor(now.timestamp() / HOUR_S) * HOUR_S
    buckets = TrackBucket.objects.filter(
        vessel=vessel, width=HOUR_S, start__gte=hour - ENDURANCE_HOURS * HOUR_S, start__lt=hour
    ).values_list("start", "channels")
    empty = settings.ALERTS_BATTERY_EMPTY_V if empty_v is None else empty_v
    means = hourly_means_from_channels(list(buckets))
    return endurance_hours(means, empty_v=empty, now_s=now.timestamp())
