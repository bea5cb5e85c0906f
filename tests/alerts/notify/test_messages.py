"""What an alert event says (alerts.notify.messages) and its webhook signature
(alerts.notify.signing): pure, no database, no server."""

from __future__ import annotations

import datetime as dt
import hashlib
import hmac
from types import SimpleNamespace

from hypothesis import given
from hypothesis import strategies as st

from alerts.notify import messages, signing
from alerts.notify.webhook import body_of
from sms import gsm7
from tests.alerts.notify.conftest import verify_shoreside

BASE = dt.datetime(2026, 11, 28, 3, 12, 7, tzinfo=dt.UTC)


def alert(slug: str = "spab", rule: str = "Overdue", pk: int = 7, **fields: object):
    values = {
        "pk": pk,
        "vessel": SimpleNamespace(slug=slug, name=slug.upper()),
        "rule": SimpleNamespace(name=rule),
        "kind": "overdue",
        "state": "open",
        "opened_at": BASE,
        "acknowledged_at": None,
        "acknowledged_by": "",
        "resolved_at": None,
        "detail": "silent 25 min (3 periods of 10 s)",
    }
    values.update(fields)
    return SimpleNamespace(**values)


def test_the_webhook_payload_has_exactly_the_documented_keys() -> None:
    body = messages.payload("alert.opened", alert())
    assert body == {
        "event": "alert.opened",
        "alert": {
            "id": 7,
            "vessel": "spab",
            "rule": "Overdue",
            "kind": "overdue",
            "state": "open",
            "opened_at": "2026-11-28T03:12:07Z",
            "acknowledged_at": None,
            "acknowledged_by": None,
            "resolved_at": None,
            "detail": "silent 25 min (3 periods of 10 s)",
        },
    }


def test_an_acknowledgement_names_who_and_when() -> None:
    acked = alert(state="acknowledged", acknowledged_at=BASE + dt.timedelta(minutes=3),
                  acknowledged_by="alice")  # fmt: skip
    message = messages.single("alert.acknowledged", acked)
    assert message.sms == "ACK spab 03:15Z Overdue by alice"
    assert message.payload["alert"]["acknowledged_by"] == "alice"
    assert message.payload["alert"]["acknowledged_at"] == "2026-11-28T03:15:07Z"
    assert "Acknowledged:  2026-11-28 03:15:07 UTC by alice" in message.body


def test_an_opened_alert_reads_what_and_where_first() -> None:
    message = messages.single("alert.opened", alert())
    assert message.sms == "ALERT spab 03:12Z Overdue: silent 25 min (3 periods of 10 s)"
    assert message.subject == "[Shoreside] ALERT SPAB (spab): Overdue"
    assert "Alert opened: Overdue on SPAB (spab)." in message.body


def test_a_long_detail_is_cut_to_one_sms_of_typeable_gsm7() -> None:
    long = alert(detail="humidity 93 % {rising} [leak?] ~ " + "é€ł " * 80)
    text = messages.single("alert.opened", long).sms
    assert len(text) == gsm7.SMS_SEPTETS and text.endswith("...")
    assert gsm7.is_gsm7(text)
    assert not set(text) & set(gsm7.EXTENSION)  # no escape bytes for the modem to type
    assert "(rising) (leak?) -" in text


@given(st.text(max_size=400))
def test_any_detail_fits_one_sms(detail: str) -> None:
    text = messages.sms_text("alert.opened", alert(detail=detail))
    assert gsm7.is_gsm7(text) and len(text) <= gsm7.SMS_SEPTETS
    assert not set(text) & (set(gsm7.EXTENSION) | {"Ξ"})


def test_a_summary_names_the_vessels_by_rule_and_counts_the_rest() -> None:
    flood = [alert(f"boat-{i:02d}", pk=i) for i in range(20)] + [alert("glider", "Battery low")]
    message = messages.summary("alert.opened", flood)
    assert message.payload is None  # webhooks are never summarised
    assert message.sms.startswith("ALERT x21 03:12Z Overdue: boat-00, boat-01, ")
    assert message.sms.endswith(" more")
    assert len(message.sms) <= gsm7.SMS_SEPTETS
    named = message.sms.count("boat-") + message.sms.count("glider")
    assert message.sms.endswith(f" +{21 - named} more")
    assert message.subject.startswith("[Shoreside] ALERT x21: 21 alerts opened")
    for a in flood:  # the e-mail lists every one
        assert f"- {a.vessel.slug}: {a.rule.name}, 2026-11-28 03:12:07 UTC" in message.body


def test_a_small_summary_names_everyone() -> None:
    few = [alert("a", pk=1), alert("b", pk=2), alert("c", "Battery low", pk=3)]
    assert messages.summary("alert.resolved", few).sms == (
        "CLEAR x3 03:12Z Overdue: a, b; Battery low: c"
    )


def test_the_signature_is_hmac_sha256_of_timestamp_dot_body() -> None:
    body = body_of(messages.payload("alert.opened", alert()))
    expected = hmac.new(b"s3cret", b"1764299527." + body, hashlib.sha256).hexdigest()
    assert signing.signature("s3cret", 1764299527, body) == f"sha256={expected}"


def test_a_receiver_accepts_a_fresh_signature_and_refuses_tampering_and_replays() -> None:
    body = body_of(messages.payload("alert.opened", alert()))
    headers = signing.headers("s3cret", 1_000_000, body)
    assert verify_shoreside("s3cret", headers, body, now=1_000_100)
    assert signing.verify("s3cret", headers[signing.TIMESTAMP_HEADER],
                          headers[signing.SIGNATURE_HEADER], body, now=1_000_100)  # fmt: skip
    assert not verify_shoreside("s3cret", headers, body.replace(b"spab", b"spac"), now=1_000_100)
    assert not verify_shoreside("other", headers, body, now=1_000_100)
    assert not verify_shoreside("s3cret", headers, body, now=1_000_301)  # over 5 minutes old
    assert not signing.verify("s3cret", "soon", headers[signing.SIGNATURE_HEADER], body, now=0)
