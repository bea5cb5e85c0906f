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
