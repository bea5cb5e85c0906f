"""The legacy SPAB `requestCommands.cgi` (docs/api.md) with the command uid as a stable taskId."""

from __future__ import annotations

import pytest
from rest_framework.test import APIClient

from commands.lifecycle import Status
from commands.models import Command
from commands.services import command_enqueue
from tests.conftest import boat_client
from tests.support import LEGACY_COMMANDS
from vessels.models import Vessel


@pytest.fixture(autouse=True)
def _no_move_to_limit(settings) -> None:
    # These tests are about delivery, not how far a move_to may go (MOVE_TO_MAX_M,
    # tests/commands/test_move_limit.py): their vessels have no fix and far-apart targets.
    settings.MOVE_TO_MAX_M = 0


def test_it_answers_listing_2_with_the_command_uid_as_task_id(
    boat_a: APIClient, vessel_a: Vessel, glider: Vessel
) -> None:
    first = command_enqueue(
        vessel=vessel_a, kind="move_to", params={"lat": -31.9505, "lon": 115.8605}
    )
    # Two move_to commands would supersede each other; the original client's example has two, so the
    # second arrives as its own (already sent) navigation order: deliver one, then queue.
    response = boat_a.get(LEGACY_COMMANDS)
    assert response.status_code == 200
    assert response.json() == [
        {"type": "command"},
        {
            "action": "moveTo",
            "latitude": -31.9505,
            "longitude": 115.8605,
            "timestamp": int(first.created_at.timestamp()),
            "taskId": str(first.uid),
        },
    ]
    second = command_enqueue(
        vessel=vessel_a, kind="move_to", params={"lat": -30.1505, "lon": 116.8705}
    )
    hold = command_enqueue(vessel=vessel_a, kind="hold", params={})
    command_enqueue(vessel=vessel_a, kind="arm", params={})  # no legacy form: never offered
    response = boat_a.get(LEGACY_COMMANDS)
    second.refresh_from_db()
    assert second.status == Status.SUPERSEDED  # the newer hold replaced it before delivery
    assert response.json() == [
        {"type": "command"},
        {"action": "hold", "timestamp": int(hold.created_at.timestamp()), "taskId": str(hold.uid)},
    ]


def test_a_delivered_legacy_command_counts_as_acknowledged(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    command = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31, "lon": 115})
    boat_a.get(LEGACY_COMMANDS)
    command.refresh_from_db()
    assert command.status == Status.ACKNOWLEDGED
    assert [e.to_status for e in command.events.all()] == ["queued", "sent", "acknowledged"]
    # The old client cannot dedupe, so it is not handed the same waypoint again.
    assert boat_a.get(LEGACY_COMMANDS).json() == [{"type": "command"}]


def test_the_task_id_is_stable_between_the_v1_and_legacy_polls(
    boat_a: APIClient, vessel_a: Vessel
) -> None:
    command = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31, "lon": 115})
    v1 = boat_a.get("/api/v1/boat/commands/").json()["commands"][0]["uid"]
    legacy = boat_a.get(LEGACY_COMMANDS).json()[1]["taskId"]
    assert v1 == legacy == str(command.uid)
    assert command.events.filter(to_status="sent").count() == 1


def test_another_boats_commands_are_never_listed(boat_b: APIClient, vessel_a: Vessel) -> None:
    command = command_enqueue(vessel=vessel_a, kind="hold", params={})
    assert boat_b.get(LEGACY_COMMANDS).json() == [{"type": "command"}]
    command.refresh_from_db()
    assert command.status == Status.QUEUED
    assert Command.objects.filter(vessel=vessel_a, status="queued").count() == 1


def test_the_api_key_header_persona_works_on_legacy_commands(key_a: str) -> None:
    assert boat_client(key_a).get(LEGACY_COMMANDS).json() == [{"type": "command"}]


def test_head_on_request_commands_hands_nothing_over(boat_a: APIClient, vessel_a: Vessel) -> None:
    command = command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": -31.9, "lon": 115.8})
    response = boat_a.head(LEGACY_COMMANDS)
    assert response.status_code == 200
    assert response.content == b""
    command.refresh_from_db()
    assert command.status == Status.QUEUED
    assert [c["taskId"] for c in boat_a.get(LEGACY_COMMANDS).json()[1:]] == [str(command.uid)]
