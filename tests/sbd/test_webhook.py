"""POST /api/v1/sbd/rockblock/: signed deliveries in, everything else refused and logged."""

from __future__ import annotations

import base64
import datetime as dt
import hashlib
import hmac
import json
import logging
from typing import Any

import pytest
from django.test import Client

from edge_client.contract import compact
from sbd.models import Direction, SbdMessage, Status
from telemetry.models import Fix
from tests.sbd.conftest import IMEI, SENT, URL, Provider, pem, private_key
from vessels.models import Vessel

pytestmark = pytest.mark.django_db

FIXES = [
    {
        "time": "2026-11-28T10:30:00+00:00",
        "lat": -32.05,
        "lon": 115.74,
        "heading_deg": 80,
        "speed_mps": 1.2,
        "battery_v": 12.6,
    },
    {"time": "2026-11-28T10:40:00+00:00", "lat": -32.051, "lon": 115.745, "battery_v": 12.55},
]


def post(client: Client, form: dict[str, str]) -> Any:
    return client.post(URL, form)


def test_a_signed_delivery_stores_the_payloads_fixes(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    payload = compact.encode(FIXES)
    response = post(webhook, provider.delivery(payload))
    assert response.status_code == 200, response.content
    assert response.json() == {"status": "stored", "fixes": 2}
    message = SbdMessage.objects.get()
    assert (message.direction, message.vessel, message.imei, message.momsn) == (
        Direction.IN,
        sbd_vessel,
        IMEI,
        1,
    )
    assert message.transmit_time == SENT and message.status == Status.DECODED
    assert bytes(message.payload) == payload and message.bytes == len(payload)
    assert (message.iridium_lat, message.iridium_lon, message.iridium_cep_km) == (
        -32.0512,
        115.7421,
        3.0,
    )
    fixes = list(Fix.objects.filter(vessel=sbd_vessel).order_by("recorded_at"))
    positions = [x for f in fixes for x in (f.lat, f.lon)]
    assert positions == pytest.approx([-32.05, 115.74, -32.051, 115.745], abs=2e-5)
    assert fixes[0].battery_v == pytest.approx(12.6) and fixes[0].heading_deg == 80
    sbd_vessel.refresh_from_db()
    assert sbd_vessel.last_fix_at == dt.datetime(2026, 11, 28, 10, 40, tzinfo=dt.UTC)


def test_readings_come_by_the_vessels_channel_table(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    sbd_vessel.compact_channels = [{"name": "humidity_pct", "step": 0.1}]
    sbd_vessel.save()
    table = sbd_vessel.channel_table()
    with_readings = [{**f, "readings": {"humidity_pct": 40.0 + i}} for i, f in enumerate(FIXES)]
    response = post(webhook, provider.delivery(compact.encode(with_readings, table)))
    assert response.json() == {"status": "stored", "fixes": 2}
    stored = Fix.objects.filter(vessel=sbd_vessel).order_by("recorded_at")
    assert [f.readings for f in stored] == [{"humidity_pct": 40.0}, {"humidity_pct": 41.0}]


def test_the_providers_retry_is_counted_once(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    delivery = provider.delivery(compact.encode(FIXES))
    assert post(webhook, delivery).json()["status"] == "stored"
    again = post(webhook, delivery)
    assert again.status_code == 200 and again.json() == {"status": "duplicate", "fixes": 0}
    assert SbdMessage.objects.count() == 1 and Fix.objects.count() == 2
    # The next MOMSN is a new message.
    assert post(webhook, provider.delivery(b"")).json()["status"] == "stored"
    assert SbdMessage.objects.count() == 2


def test_an_empty_payload_keeps_the_iridium_position_and_its_cep(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    response = post(webhook, provider.delivery(b""))
    assert response.json() == {"status": "stored", "fixes": 1}
    message = SbdMessage.objects.get()
    assert message.status == Status.POSITION_ONLY and message.bytes == 0
    fix = Fix.objects.get()
    assert (fix.recorded_at, fix.lat, fix.lon) == (SENT, -32.0512, 115.7421)
    assert fix.readings == {"iridium_cep_km": 3.0}


def test_an_undecodable_payload_is_logged_and_the_position_still_kept(
    webhook: Client, provider: Provider, sbd_vessel: Vessel, caplog: Any
) -> None:
    with caplog.at_level(logging.WARNING, logger="sbd"):
        response = post(webhook, provider.delivery(b"hello from the boat"))
    assert response.status_code == 200 and response.json()["fixes"] == 1
    message = SbdMessage.objects.get()
    assert message.status == Status.UNDECODABLE
    assert message.detail.startswith("payload refused: not a compact payload")
    assert Fix.objects.get().readings == {"iridium_cep_km": 3.0}
    assert "payload refused" in caplog.text and IMEI in caplog.text


def test_a_damaged_payload_is_refused_never_misread(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    payload = bytearray(compact.encode(FIXES))
    payload[9] ^= 0x10
    post(webhook, provider.delivery(bytes(payload)))
    assert SbdMessage.objects.get().status == Status.UNDECODABLE
    assert [f.readings for f in Fix.objects.all()] == [{"iridium_cep_km": 3.0}]


def test_an_unknown_imei_is_refused_logged_and_nothing_stored(
    webhook: Client, provider: Provider, sbd_vessel: Vessel, caplog: Any
) -> None:
    with caplog.at_level(logging.WARNING, logger="sbd"):
        response = post(webhook, provider.delivery(b"", imei="300434000000000"))
    assert response.status_code == 404 and response.json()["error"] == "unknown_imei"
    assert "300434000000000" in caplog.text
    assert not SbdMessage.objects.exists() and not Fix.objects.exists()


def test_an_unsigned_post_is_refused(
    webhook: Client, provider: Provider, sbd_vessel: Vessel, caplog: Any
) -> None:
    with caplog.at_level(logging.WARNING, logger="sbd"):
        response = post(webhook, provider.fields(compact.encode(FIXES)))
    assert response.status_code == 403 and response.json()["error"] == "bad_signature"
    assert "unsigned" in caplog.text
    assert not SbdMessage.objects.exists() and not Fix.objects.exists()


def test_a_post_signed_with_another_key_is_refused(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    form = provider.fields(b"")
    response = post(webhook, {**form, "JWT": provider.sign(form, key=private_key())})
    assert response.status_code == 403 and "does not verify" in response.json()["detail"]
    assert not SbdMessage.objects.exists()


def test_a_token_that_is_not_rs256_is_refused(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    form = provider.fields(b"")

    # The classic confusion: HS256 "signed" with the public key's PEM as the secret (made by
    # hand: PyJWT itself refuses to).
    def b64(raw: bytes) -> str:
        return base64.urlsafe_b64encode(raw).rstrip(b"=").decode()

    signing_input = b64(b'{"alg":"HS256","typ":"JWT"}') + "." + b64(json.dumps(form).encode())
    mac = hmac.new(provider.key_file.read_bytes(), signing_input.encode(), hashlib.sha256)
    forged = signing_input + "." + b64(mac.digest())
    assert post(webhook, {**form, "JWT": forged}).status_code == 403
    assert post(webhook, {**form, "JWT": "a.b.c"}).status_code == 403
    assert not SbdMessage.objects.exists()


def test_an_expired_token_is_refused(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    form = provider.fields(b"")
    expired = provider.sign(form, exp=int(dt.datetime.now(dt.UTC).timestamp()) - 60)
    response = post(webhook, {**form, "JWT": expired})
    assert response.status_code == 403 and "expired" in response.json()["detail"]


def test_a_signed_token_glued_to_other_fields_is_refused(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    signed = provider.delivery(b"")
    for field, value in [
        ("data", compact.encode(FIXES).hex()),
        ("iridium_latitude", "-33.0"),
        ("momsn", "999"),
    ]:
        response = post(webhook, {**signed, field: value})
        assert response.status_code == 403, field
        assert f"JWT's {field} differs" in response.json()["detail"]
    assert not SbdMessage.objects.exists()


def test_a_token_that_claims_no_imei_is_refused(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    form = provider.fields(b"")
    claims = {k: v for k, v in form.items() if k != "imei"}
    response = post(webhook, {**form, "JWT": provider.sign(claims)})
    assert response.status_code == 403 and "does not claim imei" in response.json()["detail"]


def test_without_a_key_file_everything_is_refused_as_not_configured(
    webhook: Client, provider: Provider, sbd_vessel: Vessel, settings: Any
) -> None:
    settings.SBD_ROCKBLOCK_PUBLIC_KEY_FILE = ""
    response = post(webhook, provider.delivery(b""))
    assert response.status_code == 503
    assert "SBD_ROCKBLOCK_PUBLIC_KEY_FILE" in response.json()["detail"]
    settings.SBD_ROCKBLOCK_PUBLIC_KEY_FILE = str(provider.key_file) + ".missing"
    assert post(webhook, provider.delivery(b"")).status_code == 503
    provider.key_file.write_text("not a key")
    settings.SBD_ROCKBLOCK_PUBLIC_KEY_FILE = str(provider.key_file)
    assert post(webhook, provider.delivery(b"")).status_code == 503
    assert not SbdMessage.objects.exists()


def test_a_new_key_file_is_read_without_a_restart(
    webhook: Client, provider: Provider, sbd_vessel: Vessel
) -> None:
    assert post(webhook, provider.delivery(b"")).status_code == 200
    provider.key = private_key()
    provider.key_file.write_bytes(pem(provider.key) + b"\n")  # another size: seen as changed
    assert post(webhook, provider.delivery(b"")).status_code == 200


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("imei", "30043406383969"),
        ("momsn", "-1"),
        ("momsn", "70000"),
        ("transmit_time", "2021-10-31T10:41:50"),
        ("iridium_latitude", "91"),
        ("iridium_longitude", "nan"),
        ("data", "abc"),
    ],
)
def test_a_malformed_signed_field_is_a_400_naming_it(
    webhook: Client, provider: Provider, sbd_vessel: Vessel, field: str, value: str
) -> None:
    response = post(webhook, provider.delivery(b"", **{field: value}))
    assert response.status_code == 400
    assert response.json()["detail"].startswith(field)
    assert not SbdMessage.objects.exists()


def test_only_post_is_answered(webhook: Client, provider: Provider) -> None:
    assert webhook.get(URL).status_code == 405


def test_the_database_itself_refuses_a_second_copy(provider: Provider, sbd_vessel: Vessel) -> None:
    """What decides when two copies race past the look-up: the constraint, which sbd_receive
    catches (a savepoint) and answers as a duplicate."""
    from django.db import IntegrityError, transaction

    from sbd.rockblock import parse_delivery
    from sbd.services import sbd_receive

    delivery = parse_delivery(provider.delivery(compact.encode(FIXES)))
    sbd_receive(delivery=delivery)
    with pytest.raises(IntegrityError), transaction.atomic():
        SbdMessage.objects.create(
            direction=Direction.IN,
            vessel=sbd_vessel,
            imei=IMEI,
            momsn=delivery.momsn,
            received_at=SENT,
            transmit_time=SENT,
            status=Status.DECODED,
        )
    # An outbound message has no MOMSN to collide on, and a wrapped MOMSN at another
    # transmit time is another message.
    SbdMessage.objects.create(
        direction=Direction.IN,
        vessel=sbd_vessel,
        imei=IMEI,
        momsn=delivery.momsn,
        received_at=SENT,
        transmit_time=SENT + dt.timedelta(days=400),
        status=Status.DECODED,
    )
