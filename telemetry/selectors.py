"""Telemetry reads through the ORM: a vessel's fixes in a range, and the nearest fix to a time.
The reads written out in SQL (the track overview's, the exports') are telemetry.sql's, and
their callers import them from there."""

from __future__ import annotations

import datetime as dt

from django.db.models import QuerySet

from telemetry.models import Fix
from vessels.models import Vessel


def fixes_in_range(
    *, vessel: Vessel, start: dt.datetime | None = None, end: dt.datetime | None = None
) -> QuerySet[Fix]:
    """A vessel's fixes in [start, end), on the (vessel, recorded_at) unique index."""
    fixes = Fix.objects.filter(vessel=vessel)
    if start is not None:
        fixes = fixes.filter(recorded_at__gte=start)
    if end is not None:
        fixes = fixes.filter(recorded_at__lt=end)
    return fixes


def fix_nearest(*, vessel: Vessel, when: dt.datetime) -> Fix | None:
    """The vessel's fix nearest in time to ``when`` (the earlier one on a tie)."""
    before = Fix.objects.filter(vessel=vessel, recorded_at__lte=when).order_by("-recorded_at")
    after = Fix.objects.filter(vessel=vessel, recorded_at__gt=when).order_by("recorded_at")
    candidates = [f for f in (before.first(), after.first()) if f is not None]
    if not candidates:
        return None
    return min(candidates, key=lambda f: abs((f.recorded_at - when).total_seconds()))
