"""Reads of the SBD log: what a vessel's satellite link has carried and cost."""

from __future__ import annotations

import datetime as dt
from typing import Any

from sbd.models import Direction, SbdMessage, Status
from sbd.rockblock import credits


def sbd_usage(*, vessel_id: int, since: dt.datetime) -> dict[str, Any]:
    """Messages, bytes and credits per direction since ``since``: inbound as received,
    outbound as handed to the provider (a queued or failed message costs nothing)."""
    rows = SbdMessage.objects.filter(vessel_id=vessel_id, received_at__gte=since)
    usage: dict[str, Any] = {}
    for direction in Direction:
        sizes = rows.filter(direction=direction)
        if direction == Direction.OUT:
            sizes = sizes.filter(status=Status.SENT)
        counts = list(sizes.values_list("bytes", flat=True))
        usage[direction.value] = {
            "messages": len(counts),
            "bytes": sum(counts),
            "credits": sum(credits(n) for n in counts),
        }
    return usage
