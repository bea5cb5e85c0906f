"""Operator command API: list a vessel's commands, queue one through the catalog, cancel."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from django.contrib.auth.models import User
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command
from commands.services import command_ack, command_claim_open, command_enqueue
from tests.conftest import give_position
from tests.support import cancel_url, commands_url, iso
from vessels.models import Vessel


def test_it_lists_a_vessels_commands_newest_first_with_their_history(
    operator: APIClient, vessel_a: Vessel, vessel_b: Vessel
) -> None:
    old = command_enqueue(vessel=vessel_a, kind="arm", params={})
    new = command_enqueue(vessel=vessel_a, kind="hold", params={})
    command_enqueue(vessel=vessel_b, kind="hold", params={})
    command_claim_open(vessel=vessel_a)
    command_ack(vessel=vessel_a, uid=old.uid, status="done", detail="armed")
    body = operator.get(commands_url()).json()
    results = body["results"] if isinstance(body, dict) else body
    assert [c["uid"] for c in results] == [str(new.uid), str(old.uid)]
    armed = results[1]
    assert (armed["vessel"], armed["kind"], armed["status"]) == ("spab", "arm", "done")
    assert armed["result_detail"] == "armed"
    assert [(e["from_status"], e["to_status"]) for e in armed["events"]] == [
        ("", "queued"),
        ("queued", "sent"),
        ("sent", "done"),
    ]


def test_it_creates_a_command_through_the_catalog(
    operator: APIClient, vessel_a: Vessel, operator_user: User
) -> None:
    give_position(vessel_a, lat=-32.01, lon=115.7)
    response = operator.post(
        commands_url(), {"kind": "move_to", "params": {"lat": -32, "lon": 115.7}}, format="json"
    )
    assert response.status_code == 201
    body = response.json()
    command = Command.objects.get(uid=body["uid"])
    assert (command.vessel, command.kind, command.status) == (vessel_a, "move_to", "queued")
    assert command.params == {"lat": -32.0, "lon": 115.7}
    assert (command.source, command.created_by) == ("api", "alice")
    assert body["params"] == {"lat": -32.0, "lon": 115.7}
    assert body["events"][0]["to_status"] == "queued"


@pytest.mark.parametrize(("body", "source"), [({}, "api"), ({"source": "map"}, "map")])
def test_a_created_command_records_whether_it_came_from_a_script_or_the_map(
    operator: APIClient, vessel_a: Vessel, body: dict[str, Any], source: str
) -> None:
    response = operator.post(commands_url(), {"kind": "hold", **body}, format="json")
    assert (response.status_code, response.json()["source"]) == (201, source)
    command = Command.objects.get()
    assert (command.source, command.created_by) == (source, "alice")
    assert command.events.get().detail == f"via {source}"


def test_a_created_command_may_be_urgent(operator: APIClient, vessel_a: Vessel) -> None:
    response = operator.post(commands_url(), {"kind": "hold", "urgent": True}, format="json")
    assert response.status_code == 201
    body = response.json()
    assert (body["urgent"], body["relay"], body["relayed_at"]) == (True, "", None)
    assert Command.objects.get().urgent
    plain = operator.post(commands_url(), {"kind": "hold"}, format="json").json()
    assert plain["urgent"] is False


def test_a_created_command_may_carry_its_own_expiry(operator: APIClient, vessel_a: Vessel) -> None:
    expires = dt.datetime.now(dt.UTC).replace(microsecond=0) + dt.timedelta(hours=1)
    response = operator.post(
        commands_url(), {"kind": "hold", "expires_at": iso(expires)}, format="json"
    )
    assert response.status_code == 201
    assert Command.objects.get().expires_at == expires


@pytest.mark.parametrize(
    ("slug", "body", "field", "message"),
    [
        ("spab", {"kind": "warp", "params": {}}, "kind", "unknown command kind 'warp'"),
        ("spab", {"kind": "fhead", "params": {"bearing": 1}}, "kind", "not available for mavlink"),
        ("glider", {"kind": "move_to", "params": {"lat": 0, "lon": 0}}, "kind", "not available"),
        ("spab", {"kind": "move_to", "params": {"lat": 91, "lon": 0}}, "params", "lat must be"),
        ("spab", {"kind": "move_to", "params": {"lat": True, "lon": 0}}, "params", "lat must be"),
        ("spab", {"kind": "move_to", "params": {"lat": 1}}, "params", "lon is required"),
        ("spab", {"kind": "arm", "params": {"force": 1}}, "params", "unknown parameter 'force'"),
        ("spab", {"kind": "move_to", "params": [1, 2]}, "params", "params must be an object"),
        ("glider", {"kind": "fhead", "params": {"bearing": 360}}, "params", "bearing must be"),
        (  # a typed 400 must never become 040° (issue 16 §3)
            "glider",
            {"kind": "fhead", "params": {"bearing": 400}, "source": "map"},
            "params",
            "bearing must be between 0 and 359 (got 400)",
        ),
        ("glider", {"kind": "fhead", "params": {"bearing": -20}}, "params", "(got -20)"),
        # An API client is a script or the map: it cannot pass for the admin, an SMS, a vessel.
        ("spab", {"kind": "hold", "source": "admin"}, "source", "must be api or map (got 'admin')"),
        ("spab", {"kind": "hold", "source": "sms"}, "source", "must be api or map"),
        ("spab", {"kind": "hold", "source": "vessel"}, "source", "must be api or map"),
        ("spab", {"kind": "hold", "source": "system"}, "source", "must be api or map"),
        ("spab", {"kind": "hold", "source": ["map"]}, "source", "must be api or map"),
        ("spab", {"params": {}}, "kind", "This field is required."),
        ("spab", {"kind": 0, "params": {}}, "kind", "Not a valid string."),
        ("spab", {"kind": "hold", "expires_at": "soon"}, "expires_at", "Datetime has wrong"),
        ("spab", {"kind": "hold", "urgent": "yes"}, "urgent", "Must be a valid boolean."),
        ("spab", {"kind": "hold", "urgent": 1}, "urgent", "Must be a valid boolean."),
        (
            "spab",
            {"kind": "hold", "expires_at": "2020-01-01T00:00:00Z"},
            "non_field_errors",
            "expires_at must be in the future",
        ),
    ],
)
def test_an_invalid_command_is_a_400_naming_the_field(
    operator: APIClient,
    vessel_a: Vessel,
    glider: Vessel,
    slug: str,
    body: dict[str, Any],
    field: str,
    message: str,
) -> None:
    response = operator.post(commands_url(slug), body, format="json")
    assert response.status_code == 400
    answer = response.json()
    assert answer["error"] == "invalid"
    assert list(answer["detail"]) == [field]
    assert message in answer["detail"][field][0]
    assert not Command.objects.exists()


def test_creating_for_an_unknown_vessel_is_a_404(operator: APIClient, vessel_a: Vessel) -> None:
    response = operator.post(commands_url("nope"), {"kind": "hold"}, format="json")
    assert response.status_code == 404
    assert not Command.objects.exists()


def test_malformed_json_is_a_400(operator: APIClient, vessel_a: Vessel) -> None:
    response = operator.post(commands_url(), '{"kind":', content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"


def test_a_deeply_nested_body_is_a_400(operator: APIClient, vessel_a: Vessel) -> None:
    body = '{"kind": "hold", "params": ' + "[" * 100_000 + "]" * 100_000 + "}"
    response = operator.post(commands_url(), body, content_type="application/json")
    assert response.status_code == 400
    assert response.json()["error"] == "parse_error"
    assert not Command.objects.exists()


def test_it_cancels_a_command(operator: APIClient, command_a: Command) -> None:
    response = operator.post(cancel_url(command_a.uid))
    assert response.status_code == 200
    assert response.json()["status"] == "cancelled"
    command_a.refresh_from_db()
    assert command_a.status == Status.CANCELLED
    assert command_a.events.last().actor == "alice"


def test_cancelling_a_finished_command_is_a_409(
    operator: APIClient, vessel_a: Vessel, command_a: Command
) -> None:
    command_claim_open(vessel=vessel_a)
    command_ack(vessel=vessel_a, uid=command_a.uid, status="done")
    response = operator.post(cancel_url(command_a.uid))
    assert response.status_code == 409
    assert response.json() == {
        "error": "conflict",
        "detail": "command is done; it can no longer be cancelled",
    }
    command_a.refresh_from_db()
    assert command_a.status == Status.DONE


@pytest.mark.parametrize("uid", ["nope", "00000000-0000-4000-8000-000000000000"])
def test_cancelling_an_unknown_command_is_a_404(
    operator: APIClient, vessel_a: Vessel, uid: str
) -> None:
    response = operator.post(cancel_url(uid))
    assert response.status_code == 404
    assert response.json() == {"error": "not_found", "detail": "No such command."}


def test_cancel_needs_the_change_permission_not_just_add(
    operator_user: User, command_a: Command
) -> None:
    operator_user.user_permissions.remove(
        *operator_user.user_permissions.filter(codename="change_command")
    )
    client = APIClient()
    client.force_authenticate(User.objects.get(pk=operator_user.pk))
    assert client.post(cancel_url(command_a.uid)).status_code == 403
    command_a.refresh_from_db()
    assert command_a.status == Status.QUEUED


# --- OpenAPI schema and docs page ---
