"""One batch of fixes to the shore, as JSON or as compact fixes (``[telemetry] encoding``).

Compact is a saving, never a risk: a batch the compact form cannot carry (a fix it refuses),
or that the server refuses in that form (a 400 or 415: an older server, a channel table that
differs from the vessel's on the shore), goes again as JSON at once, which the server always
takes, and the log says why. Readings not in the channel table are left out of a compact
batch; the log names each such reading once.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any

from edge_client.config import TelemetryConfig
from edge_client.contract import compact
from edge_client.outbox import Item
from edge_client.transports.base import Response, Transport, TransportError

log = logging.getLogger(__name__)

TELEMETRY_PATH = "/api/v1/boat/telemetry/"
# A compact post refused with these goes again as JSON (415: a server without compact fixes).
FALL_BACK_STATUSES = frozenset({400, 415})

_named: set[str] = set()  # readings the log has said are not in the channel table


def post_fixes(
    transport: Transport,
    items: Sequence[Item],
    telemetry: TelemetryConfig,
    headers: dict[str, str] | None = None,
) -> tuple[list[Item], Response]:
    """POST ``items`` as ``telemetry`` says; the items in the order the answer's ``rejected``
    indices count them (a compact payload holds its fixes in time order), and the answer."""
    items = list(items)
    if telemetry.encoding == "compact":
        sent = _post_compact(transport, items, telemetry, headers)
        if sent is not None:
            return sent
    response = transport.post_json(TELEMETRY_PATH, {"fixes": [i.body for i in items]}, headers)
    return items, response


def _post_compact(
    transport: Transport,
    items: list[Item],
    telemetry: TelemetryConfig,
    headers: dict[str, str] | None,
) -> tuple[list[Item], Response] | None:
    fixes = [i.body for i in items]
    try:
        ordered = [items[k] for k in compact.payload_order(fixes)]
        data = compact.encode([i.body for i in ordered], telemetry.channels, drop_unknown=True)
    except compact.CompactError as exc:
        log.warning("%d fixes cannot go compact (%s); sending them as JSON", len(items), exc)
        return None
    _name_unknown_readings(fixes, telemetry.channels)
    try:
        response = transport.post_bytes(TELEMETRY_PATH, data, compact.CONTENT_TYPE, headers)
    except TransportError as exc:
        if exc.status not in FALL_BACK_STATUSES:
            raise
        log.warning("the server refused compact fixes (%s); sending them as JSON", exc)
        return None
    return ordered, response


def _name_unknown_readings(fixes: list[Any], channels: Sequence[compact.Channel]) -> None:
    known = {c.name for c in channels}
    for fix in fixes:
        readings = fix.get("readings") if isinstance(fix, dict) else None
        for name in readings or ():
            if name not in known and name not in _named:
                _named.add(name)
                log.warning(
                    "reading %r is not in [telemetry] channels: compact fixes leave it out", name
                )
