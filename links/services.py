"""Counting a link's traffic: what the sms, sbd and HTTP paths call."""

from __future__ import annotations

import datetime as dt

from links.sql import COUNTERS, link_day_add


def link_count(
    *,
    vessel_id: int,
    transport: str,
    at: dt.datetime,
    contact: bool = False,
    **counts: int,
) -> None:
    """Add ``counts`` (messages_in, bytes_out, credits…) to ``vessel_id``'s UTC day of ``at``
    on ``transport``; ``contact``: the vessel was heard at ``at``. Runs in the caller's
    transaction, so a count stands or falls with what it counts."""
    unknown = set(counts) - set(COUNTERS)
    if unknown:
        raise ValueError(f"not a link counter: {sorted(unknown)}")
    link_day_add(
        vessel_id=vessel_id,
        day=at.astimezone(dt.UTC).date(),
        transport=transport,
        counts=counts,
        contact_at=at if contact else None,
    )
