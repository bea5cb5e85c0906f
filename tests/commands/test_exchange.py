"""One exchange per period (docs/api.md#one-exchange-per-period): the telemetry post's answer
carries the vessel's command list when it changed since the ETag the boat sends with its batch,
claimed exactly as the poll claims it."""

from __future__ import annotations

import datetime as dt
import json
from typing import Any

import pytest
from django.db import connection
from django.test.utils import CaptureQueriesContext
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from commands.services import command_enqueue
from edge_client.contract import compact, exchange
from telemetry.models import Fix
from tests.conftest import give_position
from tests.support import BROWSER_HEADERS, COMMANDS, TELEMETRY, MakeFix
from tests.telemetry.test_boat_api import SINGLE_POST_STATEMENTS
from vessels.auth import key_forget, key_is_recent
from vessels.models import Vessel

HEADER = exchange.META_KEY  # X-Commands-ETag, as the test client takes it
MINIMAL = {exchange.PREFER_META_KEY: exchange.PREFER}  # Prefer: return=minimal
EXCHANGE_KEYS = {exchange.ETAG_KEY, exchange.COMMANDS_KEY}
_seconds = iter(range(10**6))


def vessel_fixes(vessel: Vessel) -> int:
    return Fix.objects.filter(vessel=vessel).count()


def post(client: APIClient, make_fix: MakeFix, status: int = 200, **headers: str) -> Any:
    """One single-fix post (a new fix each time: never a duplicate), JSON as a boat sends it."""
    when = dt.datetime(2026, 11, 23, 9, tzinfo=dt.UTC) + dt.timedelta(seconds=next(_seconds))
    body = json.dumps({"fixes": [make_fix(time=when.isoformat())]})
    response = client.generic("POST", TELEMETRY, body, content_type="application/json", **headers)
    assert response.status_code == status, response.content
    return response


def test_without_the_header_the_answer_is_the_old_one_and_nothing_is_claimed(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix
) -> None:
    answer = post(boat_a, make_fix).json()
    assert answer == {"accepted": 1, "duplicates": 0, "rejected": []}
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED  # only a boat that asked is handed commands


def test_the_answer_carries_the_polls_list_and_claims_it_as_the_poll_does(
    boat_a: APIClient, boat_b: APIClient, vessel_a: Vessel, vessel_b: Vessel, make_fix: MakeFix
) -> None:
    """Boat A takes its list in the telemetry answer, boat B the same commands by the poll:
    the same items, ETag, transitions and events (the one claim: commands_since)."""
    for vessel in (vessel_a, vessel_b):
        give_position(vessel, lat=-31.01, lon=115.0)
        command_enqueue(vessel=vessel, kind="arm", params={})
        command_enqueue(vessel=vessel, kind="move_to", params={"lat": -31, "lon": 115})
    answer = post(boat_a, make_fix, **{HEADER: exchange.NONE_HELD}).json()
    polled = boat_b.get(COMMANDS)
    assert answer["accepted"] == 1
    assert answer["commands_etag"] == f'"c{vessel_a.pk}.2"'
    assert polled["ETag"] == f'"c{vessel_b.pk}.2"'

    def shape(commands: list[dict[str, Any]]) -> list[tuple]:
        return [(c["kind"], c["params"], c["expires_at"] is None) for c in commands]

    assert list(answer["commands"][0]) == list(polled.json()["commands"][0])  # same keys
    assert shape(answer["commands"]) == shape(polled.json()["commands"])
    for vessel in (vessel_a, vessel_b):
        commands = Command.objects.filter(vessel=vessel)
        assert {c.status for c in commands} == {Status.SENT}
        assert all(c.sent_at is not None for c in commands)
        events = CommandEvent.objects.filter(command__vessel=vessel, to_status=Status.SENT)
        assert sorted(e.actor for e in events) == ["boat", "boat"]


def test_a_batch_taken_whole_with_the_list_unchanged_is_answered_with_nothing(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix
) -> None:
    """204 No Content: no body, no content headers (exchange.SETTLED); the fix is stored."""
    etag = boat_a.get(COMMANDS)["ETag"]
    response = post(boat_a, make_fix, status=204, **{HEADER: etag}, **MINIMAL)
    assert response.content == b""
    assert set(response.headers) == set()  # the WSGI server adds its Date and Connection
    assert vessel_fixes(command_a.vessel) == 1


@pytest.mark.parametrize("prefer", [None, "return=representation", "respond-async"])
def test_without_prefer_minimal_the_answer_stays_json(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix, prefer: str | None
) -> None:
    """An edge client from before the 204 sends the ETag alone and reads JSON: it gets JSON."""
    etag = boat_a.get(COMMANDS)["ETag"]
    extra = {exchange.PREFER_META_KEY: prefer} if prefer else {}
    answer = post(boat_a, make_fix, **{HEADER: etag}, **extra).json()
    assert answer == {"accepted": 1, "duplicates": 0, "rejected": [], "commands_etag": etag}


@pytest.mark.parametrize(
    ("value", "minimal"),
    [
        ("return=minimal", True),
        ("respond-async, return=minimal", True),
        ("Return=Minimal; foo=bar", True),
        ("return = minimal", True),
        ("return=representation", False),
        ("", False),
        (None, False),
        ("return=minimalist", False),
    ],
)
def test_prefer_is_read_as_rfc_7240_lists_it(value: str | None, minimal: bool) -> None:
    assert exchange.wants_minimal(value) is minimal


def test_a_rejected_fix_is_said_even_when_the_list_is_unchanged(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix
) -> None:
    etag = boat_a.get(COMMANDS)["ETag"]
    body = json.dumps({"fixes": [make_fix(time="2026-11-23T10:00:00Z"), {"lat": 91}]})
    response = boat_a.generic(
        "POST", TELEMETRY, body, content_type="application/json", **{HEADER: etag}, **MINIMAL
    )
    assert response.status_code == 200
    answer = response.json()
    assert (answer["accepted"], len(answer["rejected"])) == (1, 1)
    assert answer["commands_etag"] == etag and exchange.COMMANDS_KEY not in answer


def test_duplicates_alone_are_settled_too(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix
) -> None:
    etag = boat_a.get(COMMANDS)["ETag"]
    body = json.dumps({"fixes": [make_fix(time="2026-11-23T10:00:00Z")]})
    for _ in range(2):  # stored, then a duplicate: both settled
        response = boat_a.generic(
            "POST", TELEMETRY, body, content_type="application/json", **{HEADER: etag}, **MINIMAL
        )
        assert response.status_code == 204


def test_a_command_queued_since_comes_in_the_next_answer_even_from_a_recent_key(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix, key_a: str
) -> None:
    """The key (and its vessel) come from the process's recent lookups: the version they
    carry is from before the command; the answer reads it afresh."""
    first = post(boat_a, make_fix, **{HEADER: exchange.NONE_HELD}).json()
    assert first["commands"] == []
    assert key_is_recent(key_a)
    give_position(vessel_a)
    command = command_enqueue(vessel=vessel_a, kind="arm", params={})
    answer = post(boat_a, make_fix, **{HEADER: first["commands_etag"]}).json()
    assert [c["uid"] for c in answer["commands"]] == [str(command.uid)]
    assert answer["commands_etag"] != first["commands_etag"]
    post(boat_a, make_fix, status=204, **{HEADER: answer["commands_etag"]}, **MINIMAL)
    command.refresh_from_db()
    assert command.status == Status.SENT


def test_a_lost_answer_is_made_good_by_the_next_one(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix
) -> None:
    """At-least-once: a boat that never read the answer still holds its old tag."""
    held = exchange.NONE_HELD
    first = post(boat_a, make_fix, **{HEADER: held}).json()
    second = post(boat_a, make_fix, **{HEADER: held}).json()
    assert first["commands"] == second["commands"] != []
    command_a.refresh_from_db()
    assert command_a.status == Status.SENT


@pytest.mark.parametrize(
    "value",
    [
        '"garbage"',
        "garbage",
        "*",  # If-None-Match's "any": here, as any other tag of no list, nothing held
        "",
        '"c999999.0"',
        '"' + "x" * 300 + '"',
    ],
)
def test_a_stale_foreign_or_bad_value_is_taken_as_none_held(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix, value: str
) -> None:
    """Never a refusal: the fixes are the post's business; the whole list follows."""
    answer = post(boat_a, make_fix, **{HEADER: value}).json()
    assert answer["accepted"] == 1
    assert [c["uid"] for c in answer["commands"]] == [str(command_a.uid)]


def test_another_vessels_tag_gets_the_full_list(
    boat_a: APIClient, boat_b: APIClient, command_a: Command, make_fix: MakeFix
) -> None:
    tag_b = boat_b.get(COMMANDS)["ETag"]
    answer = post(boat_a, make_fix, **{HEADER: tag_b}).json()
    assert len(answer["commands"]) == 1


@pytest.mark.parametrize("form", ["W/{tag}", '"other", {tag}'])
def test_a_weakened_or_listed_tag_matches_as_in_the_poll(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix, form: str
) -> None:
    etag = boat_a.get(COMMANDS)["ETag"]
    post(boat_a, make_fix, status=204, **{HEADER: form.format(tag=etag)}, **MINIMAL)


def test_the_short_way_and_drfs_whole_way_answer_alike(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix, key_a: str
) -> None:
    """The everyday post (a recent key) goes TelemetryView.dispatch's short way; a key not
    looked up lately, or a body with a charset, DRF's whole way: the same exchange."""
    answers = []
    for content_type in ("application/json", "application/json; charset=utf-8"):
        key_forget(key_a)
        body = json.dumps([make_fix(time=f"2026-11-23T08:00:0{len(answers)}Z")])
        for _ in range(2):  # the first after key_forget goes the whole way, the next short
            response = boat_a.generic(
                "POST", TELEMETRY, body, content_type=content_type, **{HEADER: '"old"'}
            )
            answers.append(response.json())
    assert len({json.dumps(a["commands"]) for a in answers}) == 1
    assert {a["commands_etag"] for a in answers} == {answers[0]["commands_etag"]}
    assert [a["accepted"] for a in answers] == [1, 0, 1, 0]


def test_a_refused_post_carries_no_commands(
    boat_a: APIClient, revoked_boat: APIClient, command_a: Command
) -> None:
    bad = boat_a.generic("POST", TELEMETRY, "{", content_type="application/json", **{HEADER: ""})
    assert bad.status_code == 400
    assert not EXCHANGE_KEYS & set(bad.json())
    refused = revoked_boat.generic(
        "POST", TELEMETRY, "[]", content_type="application/json", **{HEADER: ""}
    )
    assert refused.status_code == 401
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


def test_the_answer_carries_no_browser_headers(
    boat_a: APIClient, command_a: Command, make_fix: MakeFix
) -> None:
    response = post(boat_a, make_fix, **{HEADER: exchange.NONE_HELD})
    for header in BROWSER_HEADERS:
        assert header not in response.headers, header
    # What is left is what a boat reads (the WSGI server adds its Date and Connection).
    assert set(response.headers) == {"Content-Type", "Content-Length"}


def test_the_legacy_data_cgi_ignores_the_header(
    boat_a: APIClient, command_a: Command, key_a: str
) -> None:
    record = {"timestamp": 1_800_000_000, "latitude": -31.95, "longitude": 115.86}
    response = APIClient().generic(
        "POST",
        f"/spab/data.cgi?key={key_a}",
        json.dumps(record),
        content_type="application/json",
        **{HEADER: exchange.NONE_HELD},
    )
    assert response.status_code == 200
    assert response.json()[0] == {"type": "telemAck"}
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


@pytest.mark.django_db(transaction=True)
def test_an_exchange_with_nothing_new_costs_one_select_more(
    boat_a: APIClient, vessel_a: Vessel, make_fix: MakeFix
) -> None:
    """The single post's statements (tests/telemetry/test_boat_api.py: unchanged without the
    header) and one indexed SELECT of the vessel's commands_version: the key's vessel is a
    recent lookup's, its version up to a minute old. The poll it replaces cost a request."""
    etag = post(boat_a, make_fix, **{HEADER: exchange.NONE_HELD}).json()["commands_etag"]
    with CaptureQueriesContext(connection) as queries:
        post(boat_a, make_fix, status=204, **{HEADER: etag}, **MINIMAL)
    kinds = [q["sql"].split(None, 1)[0].upper() for q in queries]
    expected = [*SINGLE_POST_STATEMENTS[connection.vendor], "SELECT"]
    assert kinds == expected, [q["sql"][:80] for q in queries]
    assert "commands_version" in queries[-1]["sql"]


def test_a_compact_post_gets_the_exchange_as_a_json_one(
    boat_a: APIClient, command_a: Command
) -> None:
    """application/vnd.shoreside.fixes is answered as JSON is: the header works there too."""
    payload = compact.encode([{"time": 1_790_000_000, "lat": -31.95, "lon": 115.86}])
    response = boat_a.generic(
        "POST", TELEMETRY, payload, content_type=compact.CONTENT_TYPE, **{HEADER: '""'}
    )
    assert response.status_code == 200, response.content
    answer = response.json()
    assert answer["accepted"] == 1
    assert [c["uid"] for c in answer["commands"]] == [str(command_a.uid)]
