"""Commands a vessel created itself (a glider's SMS commands), reported up to the shore:
``command_record_reported`` and ``POST /api/v1/boat/commands/report/``."""

from __future__ import annotations

import datetime as dt
import json
import uuid
from typing import Any

import pytest
from rest_framework.test import APIClient

from commands.errors import CatalogError, CommandError, TransitionError
from commands.models import Command, CommandEvent
from commands.services import (
    command_cancel,
    command_claim_open,
    command_enqueue,
    command_record_reported,
    command_reports_record,
)
from tests.conftest import boat_client
from vessels.batch import Unreadable
from vessels.models import Vessel
from vessels.services import vessel_key_issue

pytestmark = pytest.mark.django_db

REPORT = "/api/v1/boat/commands/report/"
T0 = dt.datetime(2026, 11, 25, 6, 0, tzinfo=dt.UTC)


def at(seconds: int) -> dt.datetime:
    return T0 + dt.timedelta(seconds=seconds)


def report(glider: Vessel, uid: uuid.UUID, status: str, **extra: Any) -> tuple[Command, bool]:
    fields: dict[str, Any] = {"kind": "fhead", "params": {"bearing": 230}, "created_at": at(0)}
    return command_record_reported(vessel=glider, uid=uid, status=status, **(fields | extra))


def history(command: Command) -> list[tuple[str, str, str]]:
    return [
        (e.from_status, e.to_status, e.actor)
        for e in CommandEvent.objects.filter(command=command).order_by("pk")
    ]


@pytest.fixture
def glider_boat(glider: Vessel) -> APIClient:
    return boat_client(vessel_key_issue(vessel=glider, label="glider")[1])


def test_an_unknown_uid_becomes_a_reported_command_with_an_event_per_status(glider):
    uid = uuid.uuid4()
    command, changed = report(
        glider, uid, "done", source="sms", created_by="+61412345678", sent_at=at(5),
        acknowledged_at=at(6), finished_at=at(6), result_detail="C&C: ACK (accepted)",
    )  # fmt: skip
    command.refresh_from_db()
    assert changed and command.reported and command.uid == uid and command.vessel == glider
    assert (command.status, command.result_detail) == ("done", "C&C: ACK (accepted)")
    assert (command.source, command.created_by, command.created_at) == (
        "sms",
        "vessel:glider/+61412345678",
        T0,
    )
    assert (command.sent_at, command.acknowledged_at, command.finished_at) == (at(5), at(6), at(6))
    assert command.expires_at is None  # the shore never expires it
    assert history(command) == [
        ("", "queued", "vessel"),
        ("queued", "sent", "vessel"),
        ("sent", "acknowledged", "vessel"),
        ("acknowledged", "done", "vessel"),
    ]


def test_a_reported_command_moves_forward_and_old_or_repeated_reports_are_duplicates(glider):
    uid = uuid.uuid4()
    report(glider, uid, "queued")
    command, changed = report(glider, uid, "sent", sent_at=at(5))
    assert changed and command.status == "sent"
    assert report(glider, uid, "sent", sent_at=at(5))[1] is False
    assert report(glider, uid, "queued")[1] is False  # an older report, out of order
    command, changed = report(glider, uid, "failed", finished_at=at(9), result_detail="NAK")
    command.refresh_from_db()
    assert changed and (command.status, command.result_detail) == ("failed", "NAK")
    assert report(glider, uid, "acknowledged")[1] is False
    assert [e[1] for e in history(command)] == ["queued", "sent", "failed"]


def test_an_illegal_report_is_refused_naming_the_move(glider):
    uid = uuid.uuid4()
    report(glider, uid, "done", sent_at=at(1), finished_at=at(2))
    with pytest.raises(TransitionError, match="done; it cannot become failed"):
        report(glider, uid, "failed")
    sent = uuid.uuid4()
    report(glider, sent, "sent")
    with pytest.raises(TransitionError, match="expired"):
        report(glider, sent, "expired")  # only a queued command expires
    assert Command.objects.get(uid=sent).status == "sent"


def test_a_command_the_catalog_refuses_for_the_vessel_is_not_stored(glider):
    with pytest.raises(CatalogError):
        report(glider, uuid.uuid4(), "queued", params={"bearing": 999})
    with pytest.raises(CatalogError):
        report(glider, uuid.uuid4(), "queued", kind="move_to", params={"lat": 0, "lon": 0})
    assert not Command.objects.exists()


def test_another_vessels_uid_is_answered_as_an_unknown_one_and_left_alone(
    glider, vessel_a, command_a, caplog
):
    """The glider must not learn that vessel A's uid exists: the same answer as for a fresh
    uid (checked, then changed), nothing written, a warning for the operators."""
    events = history(command_a)
    _, changed = report(glider, command_a.uid, "done")
    assert changed
    command_a.refresh_from_db()
    assert command_a.status == "queued" and command_a.vessel == vessel_a
    assert list(Command.objects.values_list("pk", flat=True)) == [command_a.pk]
    assert history(command_a) == events
    assert f"glider reported another vessel's command uid {command_a.uid}" in caplog.text
    # The checks of an unknown uid still apply, with the same answers.
    with pytest.raises(CatalogError):
        report(glider, command_a.uid, "done", params={"bearing": 999})
    with pytest.raises(CatalogError):
        report(glider, uuid.uuid4(), "done", params={"bearing": 999})


def test_the_shores_own_command_is_left_alone_and_counted_a_duplicate(glider):
    own = command_enqueue(vessel=glider, kind="fhead", params={"bearing": 10})
    command, changed = report(glider, own.uid, "done", result_detail="from the glider")
    own.refresh_from_db()
    assert not changed and command.pk == own.pk
    assert (own.status, own.reported, own.result_detail) == ("queued", False, "")


def test_reported_commands_are_never_offered_superseding_nothing_nor_moving_the_etag(
    glider, glider_boat
):
    own = command_enqueue(vessel=glider, kind="fhead", params={"bearing": 10})
    first = glider_boat.get("/api/v1/boat/commands/")
    version = Vessel.objects.get(pk=glider.pk).commands_version
    report(glider, uuid.uuid4(), "queued", params={"bearing": 20})
    report(glider, uuid.uuid4(), "sent", params={"bearing": 30})
    later = uuid.uuid4()
    report(glider, later, "queued", params={"bearing": 40})
    report(glider, later, "done", finished_at=at(3))
    assert Vessel.objects.get(pk=glider.pk).commands_version == version
    again = glider_boat.get("/api/v1/boat/commands/", HTTP_IF_NONE_MATCH=first["ETag"])
    assert again.status_code == 304
    assert [c["uid"] for c in first.json()["commands"]] == [str(own.uid)]
    assert [c.uid for c in command_claim_open(vessel=glider)] == [own.uid]
    own.refresh_from_db()
    assert own.status == "sent"  # the shore's own navigation order was not superseded


def test_the_legacy_poll_never_offers_a_reported_command(vessel_a, boat_a):
    command_record_reported(
        vessel=vessel_a, uid=uuid.uuid4(), kind="move_to", params={"lat": -31.9, "lon": 115.8},
        status="queued", created_at=at(0),
    )  # fmt: skip
    assert boat_a.get("/spab/requestCommands.cgi").json() == [{"type": "command"}]
    assert Command.objects.get().status == "queued"


# --- the endpoint ----------------------------------------------------------------------------


def wire(uid: uuid.UUID, status: str = "done", **extra: Any) -> dict[str, Any]:
    return {
        "uid": str(uid), "kind": "fhead", "params": {"bearing": 230}, "source": "sms",
        "created_by": "+61412345678", "created_at": T0.isoformat(), "status": status,
        "sent_at": at(5).isoformat(), "acknowledged_at": at(6).isoformat(),
        "finished_at": at(6).isoformat(), "result_detail": "C&C: ACK (accepted)", **extra,
    }  # fmt: skip


def test_the_report_keeps_the_good_entries_and_names_the_bad_ones(glider_boat, glider):
    good, repeated = uuid.uuid4(), uuid.uuid4()
    body = {
        "commands": [
            wire(good),
            wire(repeated, "queued"),
            wire(repeated, "queued"),
            "not an object",
            wire(uuid.uuid4(), params={"bearing": 999}),
            wire(uuid.uuid4(), status="lost"),
            {"uid": "nope", "kind": "fhead"},
        ]
    }
    response = glider_boat.post(REPORT, body, format="json")
    assert response.status_code == 200
    answer = response.json()
    assert (answer["accepted"], answer["duplicates"]) == (2, 1)
    assert [r["index"] for r in answer["rejected"]] == [3, 4, 5, 6]
    assert "bearing" in str(answer["rejected"][1]["errors"])
    assert answer["rejected"][2]["errors"] == {"status": ["unknown status 'lost'"]}
    assert Command.objects.get(uid=good).status == "done"
    assert set(Command.objects.filter(reported=True).values_list("uid", flat=True)) == {
        good,
        repeated,
    }
    again = glider_boat.post(REPORT, {"commands": [wire(good), wire(repeated)]}, format="json")
    assert again.json() == {"accepted": 1, "duplicates": 1, "rejected": []}


def test_another_vessels_uid_gets_the_answer_of_a_fresh_one(glider_boat, glider, vessel_a):
    """Reporting boat A's uid once said "this uid belongs to another command"."""
    other = command_enqueue(vessel=vessel_a, kind="hold", params={})
    for extra in ({}, {"params": {"bearing": 999}}, {"status": "lost"}, {"finished_at": None}):
        answers = [
            glider_boat.post(REPORT, {"commands": [wire(uid, **extra)]}, format="json").json()
            for uid in (other.uid, uuid.uuid4())
        ]
        assert answers[0] == answers[1]
    assert answers[0]["rejected"] == [] and answers[0]["accepted"] == 1
    other.refresh_from_db()
    assert (other.vessel, other.status, other.reported) == (vessel_a, "queued", False)
    assert Command.objects.filter(vessel=glider).count() == 2  # the two fresh ones accepted


def test_the_report_needs_a_vessel_key_and_a_commands_list(anonymous, revoked_boat, glider_boat):
    assert anonymous.post(REPORT, {"commands": []}, format="json").status_code == 401
    assert revoked_boat.post(REPORT, {"commands": []}, format="json").status_code == 401
    for body in ([], {"commands": {}}, {"fixes": []}):
        response = glider_boat.post(REPORT, body, format="json")
        assert response.status_code == 400 and "commands" in response.json()["detail"]
    too_many = {"commands": [wire(uuid.uuid4())] * 201}
    assert glider_boat.post(REPORT, too_many, format="json").status_code == 400


def test_a_shore_navigation_order_never_supersedes_a_reported_one(glider):
    mirrored, _ = report(glider, uuid.uuid4(), "queued")
    command_enqueue(vessel=glider, kind="fhead", params={"bearing": 10})
    mirrored.refresh_from_db()
    assert mirrored.status == "queued"


def test_an_operator_cannot_cancel_a_command_the_vessel_only_reports(glider):
    mirrored, _ = report(glider, uuid.uuid4(), "sent")
    with pytest.raises(CommandError, match="created on the vessel"):
        command_cancel(command=mirrored, actor="alice")
    mirrored.refresh_from_db()
    assert mirrored.status == "sent"


# --- a vessel's key cannot forge the audit trail ---------------------------------------------


def test_a_reported_command_never_passes_for_an_operators(glider_boat, glider):
    """A vessel key files only SMS or vessel commands, under the vessel's own name."""
    body = {
        "commands": [
            wire(uuid.uuid4(), source="admin", created_by="alice"),
            wire(uuid.uuid4(), source="api"),
            wire(uuid.uuid4(), source="map"),
            wire(uuid.uuid4(), source="vessel", created_by="alice"),
            wire(uuid.uuid4(), source="system", created_by="bob"),  # vessel's older name
            wire(uuid.uuid4(), created_by="x" * 150),
        ]
    }
    answer = glider_boat.post(REPORT, body, format="json").json()
    assert answer["accepted"] == 3
    assert [r["index"] for r in answer["rejected"]] == [0, 1, 2]
    assert all(set(r["errors"]) == {"source"} for r in answer["rejected"])
    by = sorted(Command.objects.values_list("source", "created_by"))
    assert by[0] == ("sms", "vessel:glider/" + "x" * (150 - len("vessel:glider/")))
    assert by[1:] == [("vessel", "vessel:glider/alice"), ("vessel", "vessel:glider/bob")]
    assert not Command.objects.filter(source__in=["admin", "api", "map", "system"]).exists()


def test_a_report_with_implausible_or_disordered_times_is_rejected_naming_the_field(
    glider_boat, glider
):
    early, late = "1900-01-01T00:00:00Z", "1800-01-01T00:00:00Z"
    future = (dt.datetime.now(dt.UTC) + dt.timedelta(days=1)).isoformat()
    body = {
        "commands": [
            wire(uuid.uuid4(), created_at=early, finished_at=late),
            wire(uuid.uuid4(), finished_at=future),
            wire(uuid.uuid4(), sent_at=at(7)),  # sent after it was acknowledged (at 6)
            wire(uuid.uuid4(), created_at=at(9)),  # created after it was sent
            wire(uuid.uuid4()),
        ]
    }
    answer = glider_boat.post(REPORT, body, format="json").json()
    assert answer["accepted"] == 1
    fields = [(r["index"], *r["errors"]) for r in answer["rejected"]]
    assert fields == [
        (0, "created_at"), (1, "finished_at"), (2, "acknowledged_at"), (3, "sent_at")
    ]  # fmt: skip
    assert "2018-01-01" in answer["rejected"][0]["errors"]["created_at"][0]
    assert Command.objects.count() == 1


def test_a_known_command_cannot_move_on_with_an_implausible_time(glider):
    uid = uuid.uuid4()
    report(glider, uid, "queued")
    with pytest.raises(CommandError) as raised:
        report(
            glider, uid, "done", sent_at=at(5), finished_at=dt.datetime(1800, 1, 1, tzinfo=dt.UTC)
        )
    assert raised.value.field == "finished_at"
    assert Command.objects.get(uid=uid).status == "queued"


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("created_at", "2026-11-25T06:00:00", "needs a UTC offset"),
        ("finished_at", "2026-11-25T06:00:06", "needs a UTC offset"),
        ("created_at", "2026-11-25T06:00:00Z\x00", "Null characters are not allowed."),
    ],
)
def test_a_time_without_an_offset_or_with_a_nul_is_refused_as_telemetry_does(
    glider_boat, glider, field, value, message
):
    """A naive time was taken as UTC here while telemetry refused it: one rule now."""
    body = json.dumps({"commands": [wire(uuid.uuid4(), **{field: value}), wire(uuid.uuid4())]})
    answer = glider_boat.post(REPORT, body, content_type="application/json").json()
    assert answer["accepted"] == 1
    (rejected,) = answer["rejected"]
    assert rejected["index"] == 0 and message in rejected["errors"][field][0]
    assert Command.objects.count() == 1


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"bearing": "23\x000"}, "bearing: Null characters are not allowed."),
        ({"bearing\x00": 230}, "key 'bearing\\x00': Null characters"),
        ({"bearing": 230, "x\ud800": "y"}, "key 'x\\ud800': Surrogate"),
    ],
)
def test_params_the_database_cannot_store_are_rejected_by_index(
    glider_boat, glider, params, message
):
    """The lone surrogate in a name was a 500: the catalog's error echoed it into the reply."""
    body = json.dumps({"commands": [wire(uuid.uuid4(), params=params), wire(uuid.uuid4())]})
    response = glider_boat.post(REPORT, body, content_type="application/json")
    assert response.status_code == 200
    answer = response.json()
    assert answer["accepted"] == 1 and [r["index"] for r in answer["rejected"]] == [0]
    assert answer["rejected"][0]["errors"]["params"][0].startswith(message)


def test_one_service_answers_a_whole_report_batch(glider):
    # The batch answer is the service's, not the view's: the same from any caller.
    uid = uuid.uuid4()
    fields = {"kind": "fhead", "params": {"bearing": 230}, "created_at": at(0)}
    reports = [
        {"uid": uid, "status": "queued", **fields},
        Unreadable({"entry": ["not an object"]}),
        {"uid": uuid.uuid4(), "status": "nonsense", **fields},
        {"uid": uid, "status": "queued", **fields},  # repeated
        {"uid": uid, "status": "done", "finished_at": at(5), **fields},  # moved forward
    ]
    answer = command_reports_record(vessel=glider, reports=reports).as_dict()
    assert (answer["accepted"], answer["duplicates"]) == (2, 1)
    assert [(r["index"], *r["errors"]) for r in answer["rejected"]] == [(1, "entry"), (2, "status")]
    assert Command.objects.get(uid=uid).status == "done"
