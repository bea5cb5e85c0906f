"""Reads of the link counts: one vessel's links today and over the last week."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field

from django.db.models import Max
from django.utils import timezone

from links.models import LinkDay, Transport

WEEK_DAYS = 7


@dataclass
class Totals:
    messages_in: int = 0
    messages_out: int = 0
    bytes_in: int = 0
    bytes_out: int = 0
    credits: int = 0
    fixes_in: int = 0

    def add(self, row: LinkDay) -> None:
        for name in vars(self):
            setattr(self, name, getattr(self, name) + getattr(row, name))

    @property
    def bytes_per_fix(self) -> float | None:
        """What one fix cost in bytes received (None: no fix came this way)."""
        return self.bytes_in / self.fixes_in if self.fixes_in else None


@dataclass
class LinkUsage:
    transport: str
    last_contact_at: dt.datetime | None = None
    today: Totals = field(default_factory=Totals)
    week: Totals = field(default_factory=Totals)


def link_usage(*, vessel_id: int, now: dt.datetime | None = None) -> list[LinkUsage]:
    """Per transport: last contact (ever), today's and the last WEEK_DAYS UTC days' totals
    (today included). Two queries."""
    today = (now or timezone.now()).astimezone(dt.UTC).date()
    usage = {t.value: LinkUsage(t.value) for t in Transport}
    rows = LinkDay.objects.filter(vessel_id=vessel_id)
    for t, last in rows.values_list("transport").annotate(last=Max("last_contact_at")):
        if t in usage:
            usage[t].last_contact_at = last
    for row in rows.filter(day__gt=today - dt.timedelta(days=WEEK_DAYS), day__lte=today):
        if row.transport in usage:
            usage[row.transport].week.add(row)
            if row.day == today:
                usage[row.transport].today.add(row)
    return list(usage.values())
