"""From a mobile-originated payload to fixes in the boat API's fix shape (telemetry ingest).

The payload is the compact fix encoding of the boat–shore contract
(edge_client/contract/compact.py); when it holds no fix, the Iridium network's own position of
the modem stands in, with its circular error probable as the reading ``iridium_cep_km``.
"""

from __future__ import annotations

from typing import Any

from edge_client.contract import compact
from sbd.rockblock import Delivery
from vessels.models import Vessel

CEP_READING = "iridium_cep_km"


class PayloadError(ValueError):
    """The payload is not a compact fix payload."""


def fixes_from_payload(vessel: Vessel, payload: bytes) -> list[dict[str, Any]]:
    """The fixes ``payload`` holds, in the v1 fix shape; PayloadError if it is not one (or
    the vessel's channel table is broken)."""
    if not payload:
        return []
    try:
        return compact.decode(payload, vessel.channel_table())
    except compact.CompactError as exc:
        raise PayloadError(str(exc)) from None


def iridium_fix(delivery: Delivery) -> dict[str, Any]:
    """The network's position of the modem at the transmit time, as a fix."""
    return {
        "time": delivery.transmit_time.isoformat(),
        "lat": delivery.lat,
        "lon": delivery.lon,
        "readings": {CEP_READING: delivery.cep_km},
    }
