"""The edge client's batch of fixes as compact fixes (``[telemetry] encoding = "compact"``),
through its real HTTP transport to a live server: stored like JSON, and JSON again whenever the
compact form cannot go (edge_client/fix_upload.py)."""

from __future__ import annotations

import datetime as dt
import logging

import pytest
from django.utils import timezone

from edge_client.config import TelemetryConfig
from edge_client.contract.compact import Channel
from edge_client.fix_upload import post_fixes
from edge_client.outbox import Item, settle_fix_batch
from edge_client.transports.http import HttpTransport
from telemetry.models import Fix
from vessels.models import Vessel
from vessels.services import vessel_create, vessel_key_issue

pytestmark = pytest.mark.django_db(transaction=True)

TABLE = [{"name": "humidity_pct", "step": 0.1}]
COMPACT = TelemetryConfig(encoding="compact", channels=(Channel("humidity_pct", 0.1),))


@pytest.fixture
def boat(live_server) -> tuple[Vessel, HttpTransport]:
    vessel = vessel_create(slug="spab", name="SPAB", kind="mavlink")
    vessel.compact_channels = TABLE
    vessel.save()
    _, key = vessel_key_issue(vessel=vessel, label="upload test")
    transport = HttpTransport(base_url=live_server.url, key=key, retries=0)
    yield vessel, transport
    transport.close()


def items(n: int, *, readings: dict | None = None) -> list[Item]:
    start = timezone.now() - dt.timedelta(minutes=5)
    return [
        Item(
            id=100 + k,
            kind="fix",
            body={
                "time": (start + dt.timedelta(seconds=10 * k)).isoformat(),
                "lat": -32.05 + k * 1e-4,
                "lon": 115.74,
                "battery_v": 12.5,
                "readings": dict(readings or {"humidity_pct": 40.0 + k}),
            },
        )  # fmt: skip
        for k in range(n)
    ]


def test_a_compact_batch_is_stored_with_its_readings(boat) -> None:
    vessel, transport = boat
    sent, response = post_fixes(transport, items(5), COMPACT)
    assert response.json()["accepted"] == 5
    assert [i.id for i in sent] == [100, 101, 102, 103, 104]
    stored = Fix.objects.filter(vessel=vessel).order_by("recorded_at")
    assert [f.readings["humidity_pct"] for f in stored] == [40.0, 41.0, 42.0, 43.0, 44.0]


def test_rejected_indices_name_the_right_fixes_when_the_batch_was_out_of_order(boat) -> None:
    _, transport = boat
    batch = items(4)
    batch[1].body["time"] = (timezone.now() + dt.timedelta(days=1)).isoformat()  # refused
    shuffled = [batch[3], batch[1], batch[0], batch[2]]
    sent, response = post_fixes(transport, shuffled, COMPACT)
    settlement = settle_fix_batch([i.id for i in sent], response.json())
    assert [fix_id for fix_id, _ in settlement.rejected] == [101]
    assert sorted(settlement.remove) == [100, 101, 102, 103]


def test_readings_outside_the_table_are_left_out_and_named_once(boat, caplog) -> None:
    vessel, transport = boat
    caplog.set_level(logging.WARNING, logger="edge_client.fix_upload")
    post_fixes(transport, items(3, readings={"humidity_pct": 41.0, "salinity": 35.1}), COMPACT)
    assert [f.readings for f in Fix.objects.filter(vessel=vessel)] == [{"humidity_pct": 41.0}] * 3
    named = [r.message for r in caplog.records if "salinity" in r.message]
    said = "reading 'salinity' is not in [telemetry] channels: compact fixes leave it out"
    assert named == [said]


def test_a_table_the_shore_does_not_share_goes_again_as_json(boat, caplog) -> None:
    vessel, transport = boat
    vessel.compact_channels = [{"name": "water_temp_c", "step": 0.01}]
    vessel.save()
    caplog.set_level(logging.WARNING, logger="edge_client.fix_upload")
    sent, response = post_fixes(transport, items(2), COMPACT)
    assert response.json()["accepted"] == 2
    assert [f.readings for f in Fix.objects.filter(vessel=vessel).order_by("recorded_at")] == [
        {"humidity_pct": 40.0}, {"humidity_pct": 41.0},
    ]  # fmt: skip
    assert any("refused compact fixes" in r.message for r in caplog.records)


def test_a_fix_the_compact_form_refuses_sends_the_batch_as_json(boat, caplog) -> None:
    vessel, transport = boat
    batch = items(2)
    batch[0].body["battery_v"] = "low"  # the server rejects it alone, by index
    caplog.set_level(logging.WARNING, logger="edge_client.fix_upload")
    sent, response = post_fixes(transport, batch, COMPACT)
    answer = response.json()
    assert answer["accepted"] == 1 and [r["index"] for r in answer["rejected"]] == [0]
    assert [i.id for i in sent] == [100, 101]
    assert any("cannot go compact" in r.message for r in caplog.records)


def test_json_stays_the_default() -> None:
    assert TelemetryConfig().encoding == "json"
