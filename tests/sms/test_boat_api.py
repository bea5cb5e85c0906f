"""The shore link's boat endpoints: the vessel's authorised numbers and its SMS log upload."""

from __future__ import annotations

import datetime as dt
import json

import pytest

from commands.services import command_enqueue
from sms import language
from sms.api.boat import PARSED_MAX_BYTES
from sms.models import SmsMessage
from sms.services import authorised_number_authorise, authorised_number_deauthorise
from tests.conftest import boat_client
from vessels.services import vessel_key_issue
from vessels.text import json_size

NUMBERS = "/api/v1/boat/numbers/"
SMS = "/api/v1/boat/sms/"
AT = dt.datetime(2026, 11, 25, 6, 0, tzinfo=dt.UTC)


@pytest.fixture
def glider_boat(glider):
    return boat_client(vessel_key_issue(vessel=glider, label="glider")[1])


def entry(ident: str, **extra) -> dict:
    base = {
        "id": ident,
        "direction": "in",
        "number": "+61412345678",
        "text": "#FHEAD 230",
        "created_at": AT.isoformat(),
        "received_at": AT.isoformat(),
        "authorised": True,
        "outcome": "accepted",
    }
    return {**base, **extra}


def test_numbers_lists_only_those_that_may_address_the_vessel(glider, vessel_a, glider_boat):
    authorise = authorised_number_authorise
    authorise(number="0412 345 678", vessels=[glider], role="control", name="Ana")
    authorise(number="+61400000001", vessels=[vessel_a], role="control", name="Other boat")
    authorise(number="+61400000002", vessels=[glider, vessel_a], role="query", name="Both")
    response = glider_boat.get(NUMBERS)
    assert response.status_code == 200
    assert response.json() == {
        "numbers": [
            {"number": "+61400000002", "name": "Both", "role": "query", "active": True,
             "expires_at": None, "receives_positions": False},
            {"number": "+61412345678", "name": "Ana", "role": "control", "active": True,
             "expires_at": None, "receives_positions": False},
        ]
    }  # fmt: skip


def test_numbers_answer_304_until_the_list_changes(glider, glider_boat):
    authorised_number_authorise(number="+61412345678", vessels=[glider], role="query", name="A")
    etag = glider_boat.get(NUMBERS)["ETag"]
    again = glider_boat.get(NUMBERS, HTTP_IF_NONE_MATCH=etag)
    assert again.status_code == 304 and again.content == b""
    authorised_number_deauthorise(number="+61412345678")
    changed = glider_boat.get(NUMBERS, HTTP_IF_NONE_MATCH=etag)
    assert changed.status_code == 200
    assert changed.json()["numbers"][0]["active"] is False
    assert changed["ETag"] != etag


def test_another_boat_never_sees_the_vessels_numbers(glider, boat_a):
    authorised_number_authorise(number="+61412345678", vessels=[glider], role="control", name="A")
    assert boat_a.get(NUMBERS).json() == {"numbers": []}


def test_the_boat_endpoints_need_a_key(anonymous, revoked_boat):
    for client in (anonymous, revoked_boat):
        assert client.get(NUMBERS).status_code == 401
        assert client.post(SMS, [], format="json").status_code == 401


def test_an_upload_is_stored_once_and_a_resend_counts_as_duplicates(glider, glider_boat):
    reply = entry(
        "2", direction="out", number="+61412345678", text="#FHEAD 230 OK", outcome="",
        status="sent", sent_at=AT.isoformat(), reply_to="1", received_at=None,
    )  # fmt: skip
    batch = {"messages": [entry("1"), reply]}
    assert glider_boat.post(SMS, batch, format="json").json() == {
        "accepted": 2,
        "duplicates": 0,
        "rejected": [],
    }
    again = glider_boat.post(SMS, batch, format="json").json()
    assert again == {"accepted": 0, "duplicates": 2, "rejected": []}
    incoming = SmsMessage.objects.get(vessel=glider, origin_id="1")
    assert incoming.created_at == AT and incoming.number_e164 == "+61412345678"
    outgoing = SmsMessage.objects.get(vessel=glider, origin_id="2")
    assert outgoing.reply_to == incoming and outgoing.status == "sent"


def test_one_bad_entry_never_loses_the_good_ones(glider, glider_boat):
    bad_status = entry("b", status="sent")  # an incoming SMS has no send status
    answer = glider_boat.post(SMS, [entry("a"), bad_status, "nonsense", entry("c")], format="json")
    body = answer.json()
    assert body["accepted"] == 2 and body["duplicates"] == 0
    assert [r["index"] for r in body["rejected"]] == [1, 2]
    assert "status" in body["rejected"][0]["errors"]
    assert set(SmsMessage.objects.values_list("origin_id", flat=True)) == {"a", "c"}


def test_an_entry_stamped_by_a_reset_or_runaway_clock_is_rejected_by_index(glider, glider_boat):
    """The fixes' plausibility rule: not before 2018, not more than FIX_MAX_FUTURE_S ahead."""
    ahead = (dt.datetime.now(dt.UTC) + dt.timedelta(days=1)).isoformat()
    upload = [
        entry("a"),
        entry("b", created_at="0001-01-01T00:00:00Z"),
        entry("c", received_at="9999-12-31T00:00:00Z"),
        entry("d", modem_timestamp="1999-01-01T00:00:00Z"),
        entry("e", direction="out", status="sent", outcome="", sent_at=ahead),
        entry("f"),
    ]
    body = glider_boat.post(SMS, upload, format="json").json()
    assert (body["accepted"], body["duplicates"]) == (2, 0)
    named = [(r["index"], *r["errors"]) for r in body["rejected"]]
    assert named == [(1, "created_at"), (2, "received_at"), (3, "modem_timestamp"), (4, "sent_at")]
    assert "2018-01-01" in body["rejected"][0]["errors"]["created_at"][0]
    assert set(SmsMessage.objects.values_list("origin_id", flat=True)) == {"a", "f"}


def test_an_upload_links_only_the_vessels_own_commands(glider, vessel_a, glider_boat):
    own = command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230})
    other = command_enqueue(vessel=vessel_a, kind="hold", params={})
    glider_boat.post(SMS, [entry("1", commands=[str(own.uid), str(other.uid)])], format="json")
    stored = SmsMessage.objects.get(origin_id="1")
    assert list(stored.commands.all()) == [own]


def test_the_same_origin_id_from_two_vessels_is_two_messages(glider, glider_boat, boat_a):
    glider_boat.post(SMS, [entry("1")], format="json")
    assert boat_a.post(SMS, [entry("1")], format="json").json()["accepted"] == 1
    assert SmsMessage.objects.filter(origin_id="1").count() == 2


def test_an_upload_that_is_not_a_list_is_a_400(glider_boat):
    response = glider_boat.post(SMS, {"text": "hello"}, format="json")
    assert response.status_code == 400
    assert response.json()["error"]


@pytest.mark.parametrize(
    "odd",
    [
        {"text": "nul\x00here"},
        {"text": "lone \ud800 surrogate"},
        {"id": "x" * 65},
        {"created_at": "yesterday"},
        {"commands": "not-a-list"},
        {"commands": ["not-a-uid"]},
        {"parsed": [1, 2]},
        {"direction": "sideways"},
        {"number": ""},
        {"outcome": "stranger", "direction": "out", "status": "sent"},
    ],
)
def test_an_odd_entry_is_rejected_by_index_and_never_a_500(glider_boat, odd):
    # Encoded here with ASCII escapes: a lone surrogate is valid JSON, not valid UTF-8.
    body = json.dumps([entry("ok"), entry("odd", **odd)])
    answer = glider_boat.post(SMS, body, content_type="application/json")
    assert answer.status_code == 200
    body = answer.json()
    assert body["accepted"] + len(body["rejected"]) == 2
    assert body["accepted"] >= 1


# --- what PostgreSQL cannot store, and the size of `parsed` (issue 16) ---


@pytest.mark.parametrize(
    ("parsed", "where"),
    [
        ([{"k": "a\x00b"}], "[0].k"),
        ([{"k": "lone \ud800"}], "[0].k"),
        ([{"kind": "command"}, {"params": {"deep": ["x", "y\x00"]}}], "[1].params.deep[1]"),
        ([{"a\x00b": 1}], "key"),
        ([{"k": {"\udfff": 1}}], "key"),
    ],
)
def test_parsed_holding_nul_or_a_lone_surrogate_is_rejected_by_index_and_the_rest_stored(
    glider, glider_boat, parsed, where
):
    """A 500 on PostgreSQL once, which also lost every entry after it, even on re-send."""
    body = json.dumps([entry("a"), entry("bad", parsed=parsed), entry("c")])
    for _ in range(2):  # the re-send: the last entry was never stored either
        answer = glider_boat.post(SMS, body, content_type="application/json")
        assert answer.status_code == 200
        (rejected,) = answer.json()["rejected"]
        assert rejected["index"] == 1 and list(rejected["errors"]) == ["parsed"]
        assert where in rejected["errors"]["parsed"][0]
    assert set(SmsMessage.objects.values_list("origin_id", flat=True)) == {"a", "c"}


def test_parsed_nested_past_its_limit_is_rejected_by_index_and_the_rest_stored(glider, glider_boat):
    """892 levels parse (the parser's limit is about 900) but the ORM could not encode them: a
    RecursionError 500 that lost the entry after it, on every re-send of the glider's upload."""
    deep: list = ["x"]
    for _ in range(891):
        deep = [deep]
    body = json.dumps([entry("a"), entry("deep", parsed=[{"k": deep}]), entry("c")])
    for _ in range(2):
        answer = glider_boat.post(SMS, body, content_type="application/json")
        assert answer.status_code == 200
        (rejected,) = answer.json()["rejected"]
        assert rejected["index"] == 1
        assert "nested deeper than" in rejected["errors"]["parsed"][0]
    assert set(SmsMessage.objects.values_list("origin_id", flat=True)) == {"a", "c"}


def test_parsed_over_its_size_limit_is_rejected_naming_the_limit(glider, glider_boat):
    big = [{"text": "x" * 1000} for _ in range(PARSED_MAX_BYTES // 1000 + 1)]
    body = glider_boat.post(SMS, [entry("big", parsed=big), entry("ok")], format="json").json()
    assert body["accepted"] == 1
    (rejected,) = body["rejected"]
    assert rejected["index"] == 0
    assert f"at most {PARSED_MAX_BYTES}" in rejected["errors"]["parsed"][0]


def test_the_largest_parsed_the_glider_makes_is_taken(glider, glider_boat):
    """The cap is above what the SMS language can produce: 1,600 characters of controls in
    ten unknown commands, each echoed twice, escaped."""
    text = ";".join(["#" + "\x01" * 158] * 10)[: language.MAX_TEXT]
    parsed = [item.as_dict() for item in language.parse(text)]
    assert json_size(parsed) > PARSED_MAX_BYTES // 2
    body = glider_boat.post(SMS, [entry("worst", parsed=parsed)], format="json").json()
    assert (body["accepted"], body["rejected"]) == (1, [])
    assert SmsMessage.objects.get(origin_id="worst").parsed == parsed


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("created_at", "2026-11-25T06:00:00", "needs a UTC offset"),
        ("received_at", "2026-11-25T06:00:00", "needs a UTC offset"),
        ("created_at", "2026-11-25T06:00:00Z\x00", "Null characters"),
        ("sent_at", "2026-11-25T06:00:00\x00+05:00", "Null characters"),
    ],
)
def test_a_time_without_offset_or_with_a_nul_is_rejected_by_index(
    glider, glider_boat, field, value, message
):
    odd = entry("odd", **{field: value})
    if field == "sent_at":
        odd.update(direction="out", status="sent", outcome="")
    body = glider_boat.post(SMS, json.dumps([odd, entry("ok")]), content_type="application/json")
    body = body.json()
    assert body["accepted"] == 1
    (rejected,) = body["rejected"]
    assert rejected["index"] == 0 and message in rejected["errors"][field][0]
