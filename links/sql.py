"""The one write of the links app: add to a vessel's day on a transport, atomically.

``INSERT … ON CONFLICT DO UPDATE SET x = x + excluded.x``: two writers (an SBD webhook and a
flush of HTTP counts, two workers) both add, neither overwrites the other; SQLite (3.24+)
and PostgreSQL alike. The row's ``last_contact_at`` only moves forward.
"""

from __future__ import annotations

import datetime as dt

from django.db import connection

COUNTERS = ("messages_in", "messages_out", "bytes_in", "bytes_out", "credits", "fixes_in")
_T = "links_linkday"
_ADD = ", ".join(f"{c} = {_T}.{c} + excluded.{c}" for c in COUNTERS)
UPSERT = (
    f"INSERT INTO {_T} (vessel_id, day, transport, {', '.join(COUNTERS)}, last_contact_at) "
    f"VALUES ({', '.join(['%s'] * (4 + len(COUNTERS)))}) "
    f"ON CONFLICT (vessel_id, day, transport) DO UPDATE SET {_ADD}, "
    f"last_contact_at = CASE WHEN excluded.last_contact_at IS NULL "
    f"THEN {_T}.last_contact_at "
    f"WHEN {_T}.last_contact_at IS NULL OR excluded.last_contact_at > {_T}.last_contact_at "
    f"THEN excluded.last_contact_at ELSE {_T}.last_contact_at END"
)


def link_day_add(
    *,
    vessel_id: int,
    day: dt.date,
    transport: str,
    counts: dict[str, int],
    contact_at: dt.datetime | None = None,
) -> None:
    """Add ``counts`` (any of COUNTERS; the others 0) to the row, creating it if need be."""
    ops = connection.ops
    values = [int(counts.get(name, 0)) for name in COUNTERS]
    contact = ops.adapt_datetimefield_value(contact_at) if contact_at is not None else None
    with connection.cursor() as cursor:
        cursor.execute(
            UPSERT, [vessel_id, ops.adapt_datefield_value(day), transport, *values, contact]
        )
