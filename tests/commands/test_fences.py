"""Sending fences: the `fence` command in the catalog, fence_send (the whole set that applies
to the vessel, refusals, the audit entry) and the admin's command form."""

from __future__ import annotations

import pytest
from django.test import Client

from audit.models import AuditEntry
from commands import catalog
from commands.errors import CatalogError, CommandError
from commands.models import Command, Source
from commands.services import command_enqueue, fence_send, fence_set_params
from edge_client.contract.geo import offset
from vessels.models import Fence, Vessel

pytestmark = pytest.mark.django_db

HARBOUR = {"type": "Polygon", "coordinates": [[[115.70, -32.10], [115.80, -32.10],
                                               [115.80, -32.00], [115.70, -32.00],
                                               [115.70, -32.10]]]}  # fmt: skip
ROCK = {"type": "Point", "coordinates": [115.75, -32.05]}


def make_fence(name: str, vessel: Vessel | None, geometry=HARBOUR, **fields) -> Fence:
    fence = Fence(name=name, vessel=vessel, geometry=geometry, **fields)
    fence.full_clean()
    fence.save()
    return fence


# -- the catalog ------------------------------------------------------------------------------


def test_the_fence_kind_is_for_ardupilot_boats_and_navigates_nowhere() -> None:
    kind = catalog.get_kind("fence")
    assert kind.vessel_kinds == (catalog.MAVLINK,) and not kind.navigation
    assert kind.sms_word is None  # no text form: a fence set is no SMS
    assert kind in catalog.kinds_for(catalog.MAVLINK)
    assert kind not in catalog.kinds_for(catalog.WAVE_GLIDER)


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({}, "fences is required"),
        ({"fences": []}, "fences must be a non-empty list of fences"),
        (
            {
                "fences": [
                    {"name": "x", "inclusion": True, "polygon": [[0, 0], [1, 1], [0, 1], [1, 0]]}
                ]
            },
            "fence 1 (x): the polygon crosses itself",
        ),  # fmt: skip
        (
            {
                "fences": [
                    {"name": "x", "inclusion": True, "circle": {"lat": 0, "lon": 0, "radius_m": 0}}
                ]
            },
            "fence 1 (x): radius_m must be above 0",
        ),  # fmt: skip
        (
            {
                "fences": [
                    {
                        "name": "dateline",
                        "inclusion": True,
                        "polygon": [[-1, 179], [-1, -179], [1, -179]],
                    }
                ]
            },
            "crosses the 180° meridian",
        ),  # fmt: skip
        ({"fences": [], "extra": 1}, "unknown parameter 'extra'"),
    ],
)
def test_the_catalog_refuses_a_fence_set_the_autopilot_could_not_hold(params, message) -> None:
    with pytest.raises(CatalogError) as exc:
        catalog.validate("fence", params, vessel_kind=catalog.MAVLINK)
    assert message in exc.value.message


def test_a_fence_command_does_not_supersede_a_queued_move_to(vessel_a: Vessel) -> None:
    make_fence("Harbour", vessel_a)
    going = command_enqueue(vessel=vessel_a, kind="hold", params={})
    fenced = command_enqueue(
        vessel=vessel_a, kind="fence", params=fence_set_params(vessel=vessel_a)
    )
    going.refresh_from_db()
    assert (going.status, fenced.status) == ("queued", "queued")


# -- fence_send ---------------------------------------------------------------------------------


def test_it_sends_the_vessels_own_and_every_vessels_fences_in_one_command(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    own = make_fence("Harbour", vessel_a, notes="stay in")
    everyone = make_fence("Rock", None, geometry=ROCK, radius_m=150, inclusion=False)
    make_fence("Other harbour", vessel_b)  # another boat's: never sent to this one
    command = fence_send(fence=own, created_by="alice", source=Source.ADMIN)
    assert (command.vessel, command.kind, command.status) == (vessel_a, "fence", "queued")
    assert command.params == {
        "fences": [
            {"id": own.pk, "name": "Harbour", "inclusion": True,
             "polygon": [[-32.1, 115.7], [-32.1, 115.8], [-32.0, 115.8], [-32.0, 115.7]]},
            {"id": everyone.pk, "name": "Rock", "inclusion": False,
             "circle": {"lat": -32.05, "lon": 115.75, "radius_m": 150.0}},
        ]
    }  # fmt: skip
    entry = AuditEntry.objects.get()
    assert (entry.action, entry.actor, entry.via, entry.vessel) == (
        "fence.sent", "alice", "admin", "spab"
    )  # fmt: skip
    assert (entry.subject_type, entry.subject_id, entry.subject) == (
        "fence",
        str(own.pk),
        "Harbour",
    )
    assert entry.detail == {"command": str(command.uid), "fences": [own.pk, everyone.pk],
                            "items": 5}  # fmt: skip


def test_an_every_vessel_fence_is_sent_to_the_vessel_named(vessel_a: Vessel) -> None:
    everyone = make_fence("Rock", None, geometry=ROCK, radius_m=150, inclusion=False)
    command = fence_send(fence=everyone, vessel=vessel_a)
    assert [f["id"] for f in command.params["fences"]] == [everyone.pk]
    with pytest.raises(CommandError, match="is every vessel's: name the vessel"):
        fence_send(fence=everyone)


def test_it_refuses_another_vessels_fence_and_a_glider(
    vessel_a: Vessel, vessel_b: Vessel, glider: Vessel
) -> None:
    other = make_fence("Other harbour", vessel_b)
    with pytest.raises(CommandError) as exc:
        fence_send(fence=other, vessel=vessel_a)
    assert exc.value.message == "fence 'Other harbour' belongs to SPAB 2, not SPAB"
    everyone = make_fence("Rock", None, geometry=ROCK, radius_m=150)
    with pytest.raises(CommandError) as exc:
        fence_send(fence=everyone, vessel=glider)
    assert exc.value.message == "Wave Glider is a Wave Glider; only ArduPilot boats hold a fence"
    assert not Command.objects.exists() and not AuditEntry.objects.exists()


def test_a_set_too_big_for_the_autopilot_is_refused_and_nothing_is_written(
    vessel_a: Vessel,
) -> None:
    ring = [list(offset(-32, 115.7, i * 360 / 90, 2000))[::-1] for i in range(90)]
    big = make_fence(
        "Coast", vessel_a, geometry={"type": "Polygon", "coordinates": [ring + ring[:1]]}
    )
    with pytest.raises(CatalogError, match="need 90 autopilot items and 727 bytes"):
        fence_send(fence=big)
    assert not Command.objects.exists() and not AuditEntry.objects.exists()


def test_a_stored_fence_that_cannot_be_sent_says_which(vessel_a: Vessel) -> None:
    # The shore watches a polygon across 180° correctly; the autopilot cannot hold one.
    dateline = make_fence("Dateline", vessel_a, geometry={"type": "Polygon", "coordinates": [
        [[179.5, -17], [-179.5, -17], [-179.5, -16], [179.5, -16], [179.5, -17]]]})  # fmt: skip
    with pytest.raises(CatalogError, match=r"fence \d+ \(Dateline\): the polygon crosses the 180"):
        fence_send(fence=dateline)
    assert not Command.objects.exists()


# -- the admin's command form ---------------------------------------------------------------


def test_the_command_form_sends_the_vessels_fence_set(admin_ui: Client, vessel_a: Vessel) -> None:
    response = admin_ui.post(
        "/admin/commands/command/add/", {"vessel": vessel_a.pk, "kind": "fence"}
    )
    assert "SPAB has no fences, of its own or every vessel&#x27;s, to send" in (
        response.content.decode()
    )
    harbour = make_fence("Harbour", vessel_a)
    response = admin_ui.post(
        "/admin/commands/command/add/", {"vessel": vessel_a.pk, "kind": "fence"}
    )
    assert response.status_code == 302
    command = Command.objects.get()
    assert [f["id"] for f in command.params["fences"]] == [harbour.pk]


def test_the_command_list_names_the_fences_sent(admin_ui: Client, vessel_a: Vessel) -> None:
    make_fence("Harbour", vessel_a)
    make_fence("Rock", None, geometry=ROCK, radius_m=150, inclusion=False)
    fence_send(fence=Fence.objects.get(name="Harbour"))
    page = admin_ui.get("/admin/commands/command/").content.decode()
    assert "2 fence(s): Harbour, Rock" in page
