"""Commands to boats (docs/api.md#boat-api-v1): the poll with ETag/304, and acks."""

from __future__ import annotations

import datetime as dt
import json
import uuid
from typing import Any

import pytest
from django.contrib.auth.models import User
from django.utils import timezone
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command
from commands.services import command_cancel, command_enqueue
from tests.conftest import give_position
from tests.support import BROWSER_HEADERS, COMMANDS, ack_url
from vessels.models import Vessel

REPORT = "/api/v1/boat/commands/report/"


def test_boat_b_never_sees_boat_as_commands(
    boat_b: APIClient, command_a: Command, vessel_b: Vessel
) -> None:
    assert boat_b.get(COMMANDS).json() == {"commands": []}
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


@pytest.mark.parametrize("status", ["acknowledged", "done", "failed"])
def test_boat_b_gets_404_for_boat_as_command_uid(
    boat_a: APIClient, boat_b: APIClient, command_a: Command, status: str
) -> None:
    boat_a.get(COMMANDS)
    response = boat_b.post(ack_url(command_a.uid), {"status": status}, format="json")
    assert response.status_code == 404
    assert response.json() == {
        "error": "not_found",
        "detail": f"no command {command_a.uid} for this vessel",
    }
    command_a.refresh_from_db()
    assert command_a.status == Status.SENT


def test_boat_b_cannot_tell_a_foreign_uid_from_a_missing_one(
    boat_a: APIClient, boat_b: APIClient, command_a: Command
) -> None:
    missing = "00000000-0000-4000-8000-000000000000"
    foreign = boat_b.post(ack_url(command_a.uid), {"status": "done"}, format="json")
    absent = boat_b.post(ack_url(missing), {"status": "done"}, format="json")
    assert foreign.status_code == absent.status_code == 404
    assert foreign.json()["detail"].replace(str(command_a.uid), "X") == absent.json()[
        "detail"
    ].replace(missing, "X")


def test_a_poll_lists_open_commands_oldest_first(boat_a: APIClient, vessel_a: Vessel) -> None:
    give_position(vessel_a, lat=-31.01, lon=115.0)
    arm = command_enqueue(vessel=vessel_a, kind="arm", params={})
    nav = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31, "lon": 115})
    response = boat_a.get(COMMANDS)
    assert response.status_code == 200
    body = response.json()
    assert [c["uid"] for c in body["commands"]] == [str(arm.uid), str(nav.uid)]
    assert body["commands"][1] == {
        "uid": str(nav.uid),
        "kind": "move_to",
        "params": {"lat": -31.0, "lon": 115.0},
        "created_at": nav.created_at.isoformat(),
        "expires_at": nav.expires_at.isoformat(),
    }
    for command in (arm, nav):
        command.refresh_from_db()
        assert command.status == Status.SENT


def test_a_poll_without_news_is_a_bare_304(boat_a: APIClient, command_a: Command) -> None:
    first = boat_a.get(COMMANDS)
    etag = first["ETag"]
    assert etag.startswith('"') and etag.endswith('"')
    second = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert second.status_code == 304
    assert second.content == b""
    assert second["ETag"] == etag
    for header in BROWSER_HEADERS + ("Content-Type",):
        assert header not in second.headers, header


@pytest.mark.parametrize("form", ["W/{tag}", '"other", {tag}', '"x",W/{tag}'])
def test_a_weakened_or_listed_etag_still_matches(
    boat_a: APIClient, command_a: Command, form: str
) -> None:
    etag = boat_a.get(COMMANDS)["ETag"]
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=form.format(tag=etag))
    assert response.status_code == 304


def test_a_stale_or_foreign_etag_gets_the_full_list(
    boat_a: APIClient, boat_b: APIClient, vessel_a: Vessel, command_a: Command
) -> None:
    tag_b = boat_b.get(COMMANDS)["ETag"]
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=tag_b)
    assert response.status_code == 200
    assert len(response.json()["commands"]) == 1
    assert boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH='"garbage"').status_code == 200


def test_the_etag_changes_when_a_command_is_queued_cancelled_or_acked(
    boat_a: APIClient, vessel_a: Vessel, operator_user: User
) -> None:
    etag = boat_a.get(COMMANDS)["ETag"]
    command = command_enqueue(vessel=vessel_a, kind="arm", params={})
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert [c["uid"] for c in response.json()["commands"]] == [str(command.uid)]
    etag = response["ETag"]
    boat_a.post(ack_url(command.uid), {"status": "acknowledged"}, format="json")
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert response.json() == {"commands": []}
    etag = response["ETag"]
    other = command_enqueue(vessel=vessel_a, kind="disarm", params={})
    command_cancel(command=other, actor="alice")
    response = boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=etag)
    assert response.status_code == 200
    assert response.json() == {"commands": []}
    assert boat_a.get(COMMANDS, HTTP_IF_NONE_MATCH=response["ETag"]).status_code == 304


def test_a_sent_command_is_offered_again_until_acked(boat_a: APIClient, command_a: Command) -> None:
    for _ in range(3):
        response = boat_a.get(COMMANDS)
        assert [c["uid"] for c in response.json()["commands"]] == [str(command_a.uid)]
    assert command_a.events.filter(to_status="sent").count() == 1
    boat_a.post(ack_url(command_a.uid), {"status": "acknowledged"}, format="json")
    assert boat_a.get(COMMANDS).json() == {"commands": []}


def test_a_poll_does_not_offer_an_expired_command(boat_a: APIClient, vessel_a: Vessel) -> None:
    now = timezone.now()
    command = command_enqueue(
        vessel=vessel_a,
        kind="arm",
        params={},
        now=now - dt.timedelta(hours=1),
        expires_at=now - dt.timedelta(minutes=1),
    )
    assert boat_a.get(COMMANDS).json() == {"commands": []}
    command.refresh_from_db()
    assert command.status == Status.EXPIRED


# --- acks ---


def test_an_ack_moves_the_command_and_is_idempotent(boat_a: APIClient, command_a: Command) -> None:
    boat_a.get(COMMANDS)
    url = ack_url(command_a.uid)
    response = boat_a.post(url, {"status": "acknowledged"}, format="json")
    assert response.status_code == 200
    assert response.json() == {"uid": str(command_a.uid), "status": "acknowledged"}
    response = boat_a.post(url, {"status": "done", "detail": "arrived"}, format="json")
    assert response.json() == {"uid": str(command_a.uid), "status": "done"}
    again = boat_a.post(url, {"status": "done", "detail": "arrived"}, format="json")
    late = boat_a.post(url, {"status": "acknowledged"}, format="json")
    assert again.status_code == late.status_code == 200
    assert late.json() == {"uid": str(command_a.uid), "status": "done"}
    command_a.refresh_from_db()
    assert command_a.status == Status.DONE
    assert command_a.result_detail == "arrived"
    assert [e.to_status for e in command_a.events.all()] == [
        "queued",
        "sent",
        "acknowledged",
        "done",
    ]


def test_an_illegal_ack_is_a_409_naming_both_statuses(
    boat_a: APIClient, command_a: Command
) -> None:
    boat_a.get(COMMANDS)
    command_cancel(command=command_a, actor="alice")
    response = boat_a.post(ack_url(command_a.uid), {"status": "done"}, format="json")
    assert response.status_code == 409
    assert response.json() == {
        "error": "conflict",
        "detail": "command is cancelled; it cannot become done",
    }
    command_a.refresh_from_db()
    assert command_a.status == Status.CANCELLED


def test_a_conflicting_final_ack_is_a_409(boat_a: APIClient, command_a: Command) -> None:
    boat_a.get(COMMANDS)
    boat_a.post(ack_url(command_a.uid), {"status": "done"}, format="json")
    response = boat_a.post(ack_url(command_a.uid), {"status": "failed"}, format="json")
    assert response.status_code == 409
    command_a.refresh_from_db()
    assert command_a.status == Status.DONE


@pytest.mark.parametrize("first", [[], ["acknowledged"]])
def test_a_command_the_boat_replaced_is_acked_superseded(
    boat_a: APIClient, command_a: Command, first: list[str]
) -> None:
    boat_a.get(COMMANDS)
    for status in first:
        boat_a.post(ack_url(command_a.uid), {"status": status}, format="json")
    detail = "replaced by hold command 1234"
    response = boat_a.post(
        ack_url(command_a.uid), {"status": "superseded", "detail": detail}, format="json"
    )
    assert response.status_code == 200
    assert response.json() == {"uid": str(command_a.uid), "status": "superseded"}
    command_a.refresh_from_db()
    assert (command_a.status, command_a.result_detail) == (Status.SUPERSEDED, detail)
    assert command_a.finished_at is not None
    # Old news after it (a late acknowledged, the same ack again) changes nothing.
    for status in ("acknowledged", "superseded"):
        again = boat_a.post(ack_url(command_a.uid), {"status": status}, format="json")
        assert again.json()["status"] == "superseded"


@pytest.mark.parametrize("status", ["acknowledged", "done", "failed", "superseded"])
def test_a_command_no_poll_took_is_acked_all_the_same(
    boat_a: APIClient, command_a: Command, status: str
) -> None:
    # The boat got it by another link (an SBD message, an SMS): its ack is the delivery news.
    response = boat_a.post(ack_url(command_a.uid), {"status": status}, format="json")
    assert response.status_code == 200
    assert response.json() == {"uid": str(command_a.uid), "status": status}
    command_a.refresh_from_db()
    assert command_a.status == status and command_a.sent_at is not None
    events = [(e.from_status, e.to_status, e.actor) for e in command_a.events.all()]
    assert events[1:] == [("queued", "sent", "boat"), ("sent", status, "boat")]
    assert "another link" in command_a.events.get(to_status="sent").detail
    # The poll that comes later (HTTP is back) no longer offers it.
    assert boat_a.get(COMMANDS).json() == {"commands": []}


def test_a_command_cancelled_before_any_poll_still_refuses_an_ack(
    boat_a: APIClient, command_a: Command
) -> None:
    command_cancel(command=command_a, actor="alice")
    response = boat_a.post(ack_url(command_a.uid), {"status": "done"}, format="json")
    assert response.status_code == 409
    command_a.refresh_from_db()
    assert command_a.status == Status.CANCELLED


@pytest.mark.parametrize(
    ("body", "field", "message"),
    [
        (
            {"status": "finished"},
            "status",
            "status must be acknowledged, done, failed or superseded",
        ),
        ({}, "status", "status must be acknowledged, done, failed or superseded"),
        ({"status": True}, "status", "status must be acknowledged, done, failed or superseded"),
        ({"status": "done", "detail": 3}, "detail", "must be a string"),
        ({"status": "done", "detail": None}, "detail", "must be a string"),
    ],
)
def test_a_bad_ack_is_a_400_naming_the_field(
    boat_a: APIClient, command_a: Command, body: dict[str, Any], field: str, message: str
) -> None:
    boat_a.get(COMMANDS)
    response = boat_a.post(ack_url(command_a.uid), body, format="json")
    assert response.status_code == 400
    assert response.json() == {"error": "invalid", "detail": {field: [message]}}
    command_a.refresh_from_db()
    assert command_a.status == Status.SENT


@pytest.mark.parametrize("body", ['["done"]', '"done"', "3", "null"])
def test_an_ack_body_that_is_not_an_object_is_a_400(
    boat_a: APIClient, command_a: Command, body: str
) -> None:
    response = boat_a.post(ack_url(command_a.uid), body, content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"
    assert "Expected a JSON object" in response.json()["detail"]


def test_an_ack_with_malformed_json_is_a_400(boat_a: APIClient, command_a: Command) -> None:
    response = boat_a.post(ack_url(command_a.uid), '{"status":', content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"


@pytest.mark.parametrize("uid", ["not-a-uuid", "00000000-0000-4000-8000-000000000000"])
def test_an_ack_for_an_unknown_uid_is_a_404(boat_a: APIClient, uid: str) -> None:
    response = boat_a.post(ack_url(uid), {"status": "done"}, format="json")
    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


def test_the_ack_detail_is_kept_within_bounds(boat_a: APIClient, command_a: Command) -> None:
    boat_a.get(COMMANDS)
    boat_a.post(ack_url(command_a.uid), {"status": "failed", "detail": "x" * 5000}, format="json")
    command_a.refresh_from_db()
    assert command_a.status == Status.FAILED
    assert len(command_a.result_detail) == 2000


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("ok\x00then", "Null characters are not allowed."),
        ("ok\ud800then", "Surrogate characters are not allowed: U+D800."),
    ],
)
def test_an_ack_detail_the_database_cannot_store_is_refused_as_everywhere_else(
    boat_a: APIClient, command_a: Command, text: str, message: str
) -> None:
    """NUL (PostgreSQL text refuses it) and a lone surrogate (not UTF-8 at all) were a 500,
    then rewritten here alone; the boat API refuses them everywhere, in DRF's words."""
    boat_a.get(COMMANDS)
    body = json.dumps({"status": "failed", "detail": text})
    response = boat_a.post(ack_url(command_a.uid), body, content_type="application/json")
    assert response.status_code == 400
    assert response.json() == {"error": "invalid", "detail": {"detail": [message]}}
    report = json.dumps({"commands": [{"uid": str(uuid.uuid4()), "result_detail": text}]})
    response = boat_a.post(REPORT, report, content_type="application/json")
    assert response.json()["rejected"][0]["errors"]["result_detail"] == [message]
    command_a.refresh_from_db()
    assert (command_a.status, command_a.result_detail) == (Status.SENT, "")


# --- telemetry ---


def test_head_on_the_poll_answers_the_etag_and_hands_nothing_over(
    boat_a: APIClient, command_a: Command
) -> None:
    response = boat_a.head(COMMANDS)
    assert response.status_code == 200
    assert response.content == b""
    etag = response["ETag"]
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED
    assert boat_a.head(COMMANDS, HTTP_IF_NONE_MATCH=etag).status_code == 304
    # The command is still there for the real poll, which carries the same tag.
    polled = boat_a.get(COMMANDS)
    assert [c["uid"] for c in polled.json()["commands"]] == [str(command_a.uid)]
    assert polled["ETag"] == etag


@pytest.mark.parametrize("ended", ["cancelled", "expired"])
def test_a_relayed_command_that_ended_here_still_hears_what_the_boat_did(
    boat_a: APIClient, command_a: Command, ended: str
) -> None:
    """Relayed by SMS or SBD, then cancelled or expired here: neither link can recall it, so
    the boat may still run it. Its ack is taken (no 409 to re-send forever) and kept in the
    history; the status stays what it was."""
    Command.objects.filter(pk=command_a.pk).update(relay="sbd", status=ended)
    response = boat_a.post(
        ack_url(command_a.uid), {"status": "done", "detail": "arrived"}, format="json"
    )
    assert response.status_code == 200
    assert response.json() == {"uid": str(command_a.uid), "status": ended}
    event = command_a.events.get(actor="boat")
    assert (event.from_status, event.to_status) == (ended, ended)
    assert (
        event.detail == f"the boat reports done (it had it by sbd before it was {ended}): arrived"
    )
