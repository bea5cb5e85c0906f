"""What budget rules read: each vessel's spending today per link, and its budgets.

One query a pass for the whole fleet (LinkDay rows of today's UTC date); the budgets come
with the pass's vessel rows (BUDGET_FIELDS)."""

from __future__ import annotations

import datetime as dt
from typing import Any

from links.models import LinkDay

# A vessel's budget field per transport (vessels.models.Vessel), in BUDGET_UNITS' units.
BUDGET_FIELDS = {
    "sbd": "sbd_daily_credit_budget",
    "sms": "sms_daily_budget",
    "http": "http_daily_budget_kb",
}


def spent_today(now: dt.datetime) -> dict[tuple[int, str], float]:
    """(vessel id, transport) -> what it spent on the UTC day of ``now``: credits for SBD,
    segments for SMS, kilobytes (1000 bytes, in and out) for HTTP."""
    rows = LinkDay.objects.filter(day=now.astimezone(dt.UTC).date()).values_list(
        "vessel_id", "transport", "credits", "bytes_in", "bytes_out"
    )
    return {
        (vessel_id, transport): (b_in + b_out) / 1000 if transport == "http" else float(credits)
        for vessel_id, transport, credits, b_in, b_out in rows
    }


def budget_limit(vessel: dict[str, Any], transport: str, default: float | None) -> float | None:
    """The vessel's own daily budget on ``transport``, else the rule's ``default``."""
    own = vessel.get(BUDGET_FIELDS[transport])
    return float(own) if own is not None else default
