"""What the API tests share: endpoint paths, request helpers, the SPAB client's sample records."""

from __future__ import annotations

import datetime as dt
import json
from collections.abc import Callable
from typing import Any

from rest_framework.test import APIClient

from telemetry.parsing import LEGACY_EPOCH, LEGACY_TICKS_PER_S

TELEMETRY = "/api/v1/boat/telemetry/"
COMMANDS = "/api/v1/boat/commands/"
BROWSER_HEADERS = (
    "X-Frame-Options",
    "Referrer-Policy",
    "Vary",
    "Allow",
    "X-Content-Type-Options",
    "Cross-Origin-Opener-Policy",
    "Strict-Transport-Security",
)

MakeFix = Callable[..., dict[str, Any]]


def ack_url(uid: object) -> str:
    return f"/api/v1/boat/commands/{uid}/ack/"


def iso(when: dt.datetime) -> str:
    return when.isoformat().replace("+00:00", "Z")


def call(client: APIClient, endpoint: str, uid: object) -> Any:
    if endpoint == "telemetry":
        return client.post(TELEMETRY, [], format="json")
    if endpoint == "commands":
        return client.get(COMMANDS)
    return client.post(ack_url(uid), {"status": "acknowledged"}, format="json")


ENDPOINTS = ["telemetry", "commands", "ack"]


# --- the auth matrix ---


VESSELS = "/api/v1/vessels/"
BASE = dt.datetime(2026, 11, 23, 8, 0, tzinfo=dt.UTC)


def fixes_url(slug: str = "spab") -> str:
    return f"/api/v1/vessels/{slug}/fixes/"


def commands_url(slug: str = "spab") -> str:
    return f"/api/v1/vessels/{slug}/commands/"


def cancel_url(uid: object) -> str:
    return f"/api/v1/commands/{uid}/cancel/"


# --- the auth matrix, on every operator endpoint ---


DATA = "/spab/data.cgi"
LEGACY_COMMANDS = "/spab/requestCommands.cgi"

# The SPAB client's logging record (docs/api.md), as real JSON with the same keys and values.
LISTING_1 = [
    {
        "timestamp": 1536551550,
        "latitude": -31.9505,
        "longitude": 115.8605,
        "temperature": 301.3,
        "salinity": 35.5,
    },
    {
        "timestamp": 1536552678,
        "latitude": -30.1505,
        "longitude": 116.8705,
        "temperature": 299.1,
        "salinity": 35.5,
    },
]


def post_data(client: APIClient, body: Any, **extra: Any) -> Any:
    return client.post(DATA, json.dumps(body), content_type="application/json", **extra)


def telem_ack(response: Any) -> tuple[str, str]:
    body = response.json()
    assert body[0] == {"type": "telemAck"}
    assert set(body[1]) == {"success", "message"}
    return body[1]["success"], body[1]["message"]


def ticks(when: dt.datetime) -> int:
    """The old server's timestamp: units of 10 µs since 2015-01-01."""
    return round((when - LEGACY_EPOCH).total_seconds() * LEGACY_TICKS_PER_S)


# --- data.cgi ---
