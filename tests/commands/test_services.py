"""Command services: enqueue, supersede, claim, ack, cancel, expire — and their event log."""

from __future__ import annotations

import datetime as dt

import pytest
from django.utils import timezone

from commands.catalog import CatalogError
from commands.lifecycle import Status, TransitionError
from commands.models import Command, CommandEvent, Source
from commands.services import (
    CommandError,
    CommandNotFound,
    command_ack,
    command_cancel,
    command_claim_open,
    command_deliver_legacy,
    command_enqueue,
    command_expire_due,
)
from vessels.models import Vessel

pytestmark = pytest.mark.django_db


@pytest.fixture(autouse=True)
def _no_move_to_limit(settings) -> None:
    # These tests are about the lifecycle, not how far a move_to may go (MOVE_TO_MAX_M,
    # tests/commands/test_move_limit.py): their vessels have no fix and far-apart targets.
    settings.MOVE_TO_MAX_M = 0


def move_to(vessel: Vessel, lat: float = -31.95, **kwargs: object) -> Command:
    return command_enqueue(
        vessel=vessel, kind="move_to", params={"lat": lat, "lon": 115.86}, **kwargs
    )


def events(command: Command) -> list[tuple[str, str]]:
    return [(e.from_status, e.to_status) for e in command.events.order_by("at", "pk")]


def version(vessel: Vessel) -> int:
    vessel.refresh_from_db(fields=["commands_version"])
    return vessel.commands_version


# --- enqueue ---


def test_it_queues_a_valid_command_with_its_first_event(vessel_a: Vessel) -> None:
    now = timezone.now()
    command = command_enqueue(
        vessel=vessel_a,
        kind="move_to",
        params={"lat": -31, "lon": 115},
        source=Source.ADMIN,
        created_by="alice",
        now=now,
    )
    command.refresh_from_db()
    assert command.status == Status.QUEUED
    assert command.params == {"lat": -31.0, "lon": 115.0}
    assert (command.source, command.created_by) == ("admin", "alice")
    assert command.expires_at == now + dt.timedelta(hours=24)
    event = command.events.get()
    assert (event.from_status, event.to_status, event.actor) == ("", "queued", "alice")
    assert event.detail == "via admin"


def test_it_refuses_an_invalid_command_and_stores_nothing(vessel_a: Vessel) -> None:
    with pytest.raises(CatalogError) as err:
        command_enqueue(vessel=vessel_a, kind="move_to", params={"lat": 91, "lon": 0})
    assert err.value.field == "lat"
    with pytest.raises(CatalogError):
        command_enqueue(vessel=vessel_a, kind="fhead", params={"bearing": 10})  # glider only
    assert not Command.objects.exists()
    assert not CommandEvent.objects.exists()
    assert version(vessel_a) == 0


def test_it_refuses_commands_for_an_inactive_vessel(vessel_a: Vessel) -> None:
    Vessel.objects.filter(pk=vessel_a.pk).update(active=False)
    vessel_a.refresh_from_db()
    with pytest.raises(CommandError, match="not active"):
        command_enqueue(vessel=vessel_a, kind="hold", params={})
    assert not Command.objects.exists()


def test_it_refuses_an_expiry_in_the_past(vessel_a: Vessel) -> None:
    now = timezone.now()
    with pytest.raises(CommandError, match="expires_at must be in the future"):
        command_enqueue(vessel=vessel_a, kind="hold", params={}, expires_at=now, now=now)
    assert not Command.objects.exists()


def test_it_truncates_an_overlong_creator(vessel_a: Vessel) -> None:
    command = command_enqueue(vessel=vessel_a, kind="arm", params={}, created_by="x" * 400)
    command.refresh_from_db()
    assert len(command.created_by) == 150


def test_it_bumps_the_commands_version_on_enqueue(vessel_a: Vessel) -> None:
    before = version(vessel_a)
    command_enqueue(vessel=vessel_a, kind="arm", params={})
    assert version(vessel_a) == before + 1


# --- supersede ---


def test_a_new_navigation_command_supersedes_older_queued_ones(vessel_a: Vessel) -> None:
    first = move_to(vessel_a, lat=-31.0)
    second = command_enqueue(vessel=vessel_a, kind="return_home", params={})
    first.refresh_from_db()
    second.refresh_from_db()
    assert first.status == Status.SUPERSEDED
    assert first.finished_at is not None
    assert str(second.uid) in first.result_detail
    assert events(first) == [("", "queued"), ("queued", "superseded")]
    assert first.events.last().actor == "system"
    assert second.status == Status.QUEUED


def test_it_never_supersedes_a_command_already_sent(vessel_a: Vessel) -> None:
    first = move_to(vessel_a)
    command_claim_open(vessel=vessel_a)
    move_to(vessel_a, lat=-30.0)
    first.refresh_from_db()
    assert first.status == Status.SENT


def test_it_supersedes_only_the_same_vessels_commands(vessel_a: Vessel, vessel_b: Vessel) -> None:
    other = move_to(vessel_b)
    move_to(vessel_a)
    other.refresh_from_db()
    assert other.status == Status.QUEUED


def test_non_navigation_commands_neither_supersede_nor_get_superseded(
    vessel_a: Vessel, glider: Vessel
) -> None:
    arm = command_enqueue(vessel=vessel_a, kind="arm", params={})
    nav = move_to(vessel_a)
    command_enqueue(vessel=vessel_a, kind="disarm", params={})
    move_to(vessel_a, lat=-30)
    light = command_enqueue(vessel=glider, kind="light", params={"state": "on"})
    waypoint = command_enqueue(
        vessel=glider, kind="waypoint", params={"index": 1, "lat": -32.038, "lon": 115.3325}
    )
    command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230})
    command_enqueue(vessel=glider, kind="hold", params={})
    for command in (arm, nav, light, waypoint):
        command.refresh_from_db()
    assert arm.status == Status.QUEUED
    assert nav.status == Status.SUPERSEDED
    assert light.status == Status.QUEUED
    assert waypoint.status == Status.QUEUED
    assert Command.objects.get(kind="fhead").status == Status.SUPERSEDED


def test_superseding_bumps_the_commands_version(vessel_a: Vessel) -> None:
    move_to(vessel_a)
    before = version(vessel_a)
    move_to(vessel_a, lat=-30)
    # One bump for the new command, one for the superseded one leaving the list.
    assert version(vessel_a) == before + 2


# --- claim (the boat poll) ---


def test_claiming_marks_queued_commands_sent_once_and_offers_them_again(vessel_a: Vessel) -> None:
    arm = command_enqueue(vessel=vessel_a, kind="arm", params={})
    nav = move_to(vessel_a)
    first = command_claim_open(vessel=vessel_a)
    assert [c.uid for c in first] == [arm.uid, nav.uid]  # oldest first
    assert {c.status for c in first} == {Status.SENT}
    before = version(vessel_a)
    again = command_claim_open(vessel=vessel_a)
    assert [c.uid for c in again] == [arm.uid, nav.uid]
    for command in (arm, nav):
        command.refresh_from_db()
        assert command.status == Status.SENT
        assert command.sent_at is not None
        assert events(command) == [("", "queued"), ("queued", "sent")]
    assert version(vessel_a) == before  # queued→sent leaves the boat's list unchanged


def test_a_command_cancelled_while_a_poll_claims_it_is_not_handed_out(
    vessel_a: Vessel, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The poll reads the queued list, then an operator's cancel commits before the poll's
    # queued→sent UPDATE: the poll loses that race and must not give the boat the command.
    from commands.services import delivery

    real = delivery._transition
    raced: list[Command] = []

    def cancel_first(command: Command, target: Status, **kwargs: object) -> bool:
        if target == Status.SENT and not raced:
            raced.append(command)
            command_cancel(command=Command.objects.get(pk=command.pk), actor="alice")
        return real(command, target, **kwargs)

    cancelled = command_enqueue(vessel=vessel_a, kind="arm", params={})
    kept = command_enqueue(vessel=vessel_a, kind="disarm", params={})
    monkeypatch.setattr(delivery, "_transition", cancel_first)
    offered = command_claim_open(vessel=vessel_a)
    assert [c.uid for c in offered] == [kept.uid]
    cancelled.refresh_from_db()
    assert events(cancelled) == [("", "queued"), ("queued", "cancelled")]


def test_claiming_sees_only_this_vessels_open_commands(vessel_a: Vessel, vessel_b: Vessel) -> None:
    mine = move_to(vessel_a)
    move_to(vessel_b)
    done = command_enqueue(vessel=vessel_a, kind="arm", params={})
    command_claim_open(vessel=vessel_a)
    command_ack(vessel=vessel_a, uid=done.uid, status="done")
    assert [c.uid for c in command_claim_open(vessel=vessel_a)] == [mine.uid]


def test_claiming_expires_overdue_commands_instead_of_sending_them(vessel_a: Vessel) -> None:
    now = timezone.now()
    command = move_to(vessel_a, now=now, expires_at=now + dt.timedelta(seconds=10))
    assert command_claim_open(vessel=vessel_a, now=now + dt.timedelta(seconds=11)) == []
    command.refresh_from_db()
    assert command.status == Status.EXPIRED
    assert command.sent_at is None


# --- ack ---


@pytest.fixture
def sent(vessel_a: Vessel) -> Command:
    command = move_to(vessel_a)
    command_claim_open(vessel=vessel_a)
    command.refresh_from_db()
    return command


def test_it_records_acknowledged_then_done(vessel_a: Vessel, sent: Command) -> None:
    before = version(vessel_a)
    command, changed = command_ack(vessel=vessel_a, uid=sent.uid, status="acknowledged")
    assert changed
    command, changed = command_ack(
        vessel=vessel_a, uid=str(sent.uid), status="done", detail="arrived"
    )
    assert changed
    sent.refresh_from_db()
    assert sent.status == Status.DONE
    assert sent.acknowledged_at is not None
    assert sent.finished_at is not None
    assert sent.result_detail == "arrived"
    assert events(sent)[-2:] == [("sent", "acknowledged"), ("acknowledged", "done")]
    assert sent.events.last().actor == "boat"
    # Leaving the boat's list (acknowledged) changes the ETag; so does each later transition.
    assert version(vessel_a) == before + 2


def test_a_repeated_ack_changes_nothing(vessel_a: Vessel, sent: Command) -> None:
    command_ack(vessel=vessel_a, uid=sent.uid, status="done")
    count, before = CommandEvent.objects.count(), version(vessel_a)
    command, changed = command_ack(vessel=vessel_a, uid=sent.uid, status="done")
    assert not changed
    assert command.status == Status.DONE
    assert CommandEvent.objects.count() == count
    assert version(vessel_a) == before


def test_a_stale_ack_after_done_changes_nothing(vessel_a: Vessel, sent: Command) -> None:
    command_ack(vessel=vessel_a, uid=sent.uid, status="done")
    count = CommandEvent.objects.count()
    command, changed = command_ack(vessel=vessel_a, uid=sent.uid, status="acknowledged")
    assert not changed
    sent.refresh_from_db()
    assert sent.status == Status.DONE
    assert CommandEvent.objects.count() == count


def test_a_boat_may_report_done_without_acknowledging_first(
    vessel_a: Vessel, sent: Command
) -> None:
    command_ack(vessel=vessel_a, uid=sent.uid, status="done")
    sent.refresh_from_db()
    assert events(sent)[-1] == ("sent", "done")


@pytest.mark.parametrize(
    ("first", "then"),
    [("done", "failed"), ("failed", "done")],
)
def test_a_conflicting_final_ack_is_an_illegal_transition(
    vessel_a: Vessel, sent: Command, first: str, then: str
) -> None:
    command_ack(vessel=vessel_a, uid=sent.uid, status=first)
    with pytest.raises(TransitionError) as err:
        command_ack(vessel=vessel_a, uid=sent.uid, status=then)
    assert (err.value.current, err.value.target) == (first, then)
    sent.refresh_from_db()
    assert sent.status == first


@pytest.mark.parametrize("then", ["done", "failed"])
def test_superseded_is_final_like_done_and_failed(
    vessel_a: Vessel, sent: Command, then: str
) -> None:
    command_ack(vessel=vessel_a, uid=sent.uid, status="acknowledged")
    command, changed = command_ack(vessel=vessel_a, uid=sent.uid, status="superseded")
    assert changed and command.status == Status.SUPERSEDED
    assert events(sent)[-1] == ("acknowledged", "superseded")
    with pytest.raises(TransitionError):
        command_ack(vessel=vessel_a, uid=sent.uid, status=then)


def test_acking_a_cancelled_command_is_an_illegal_transition(
    vessel_a: Vessel, sent: Command
) -> None:
    command_cancel(command=sent, actor="alice")
    with pytest.raises(TransitionError):
        command_ack(vessel=vessel_a, uid=sent.uid, status="done")
    sent.refresh_from_db()
    assert sent.status == Status.CANCELLED


def test_acking_a_command_no_poll_took_records_its_delivery_first(vessel_a: Vessel) -> None:
    command = move_to(vessel_a)  # queued: it went by SBD or SMS, which cannot tell delivery
    command, changed = command_ack(vessel=vessel_a, uid=command.uid, status="acknowledged")
    assert changed and command.status == Status.ACKNOWLEDGED
    assert events(command)[-2:] == [("queued", "sent"), ("sent", "acknowledged")]


@pytest.mark.parametrize("status", ["sent", "cancelled", "DONE", "", None, 3])
def test_it_refuses_a_status_a_boat_cannot_report(
    vessel_a: Vessel, sent: Command, status: object
) -> None:
    with pytest.raises(CommandError, match="acknowledged, done, failed or superseded"):
        command_ack(vessel=vessel_a, uid=sent.uid, status=status)  # type: ignore[arg-type]


def test_another_vessels_command_is_not_found(vessel_b: Vessel, sent: Command) -> None:
    with pytest.raises(CommandNotFound):
        command_ack(vessel=vessel_b, uid=sent.uid, status="done")
    sent.refresh_from_db()
    assert sent.status == Status.SENT


@pytest.mark.parametrize("uid", ["not-a-uid", "", "00000000-0000-0000-0000-000000000000"])
def test_an_unknown_uid_is_not_found(vessel_a: Vessel, uid: str) -> None:
    with pytest.raises(CommandNotFound):
        command_ack(vessel=vessel_a, uid=uid, status="done")


# --- cancel ---


def test_it_cancels_a_queued_command(vessel_a: Vessel) -> None:
    command = move_to(vessel_a)
    before = version(vessel_a)
    command_cancel(command=command, actor="alice")
    command.refresh_from_db()
    assert command.status == Status.CANCELLED
    assert command.result_detail == "cancelled by operator"
    assert events(command)[-1] == ("queued", "cancelled")
    assert command.events.last().actor == "alice"
    assert version(vessel_a) == before + 1


def test_it_cancels_a_sent_command_warning_it_may_have_arrived(sent: Command) -> None:
    command_cancel(command=sent, actor="alice")
    sent.refresh_from_db()
    assert sent.status == Status.CANCELLED
    assert "may already have reached the vessel" in sent.result_detail


@pytest.mark.parametrize("final", ["acknowledged", "done", "failed"])
def test_it_cannot_cancel_what_the_boat_already_took(
    vessel_a: Vessel, sent: Command, final: str
) -> None:
    command_ack(vessel=vessel_a, uid=sent.uid, status=final)
    count = CommandEvent.objects.count()
    with pytest.raises(TransitionError):
        command_cancel(command=sent, actor="alice")
    sent.refresh_from_db()
    assert sent.status == final
    assert CommandEvent.objects.count() == count


def test_cancelling_twice_is_refused(vessel_a: Vessel) -> None:
    command = move_to(vessel_a)
    command_cancel(command=command, actor="alice")
    with pytest.raises(TransitionError):
        command_cancel(command=command, actor="alice")
    assert command.events.filter(to_status="cancelled").count() == 1


def test_cancel_reads_the_current_status_not_a_stale_copy(vessel_a: Vessel) -> None:
    command = move_to(vessel_a)
    stale = Command.objects.get(pk=command.pk)
    command_claim_open(vessel=vessel_a)
    command_cancel(command=stale, actor="alice")
    assert events(stale)[-1] == ("sent", "cancelled")


# --- expire ---


def test_it_expires_only_queued_commands_past_their_expiry(
    vessel_a: Vessel, vessel_b: Vessel
) -> None:
    now = timezone.now()
    soon = now + dt.timedelta(minutes=5)
    due = command_enqueue(vessel=vessel_a, kind="arm", params={}, expires_at=soon, now=now)
    later = command_enqueue(
        vessel=vessel_a, kind="disarm", params={}, expires_at=now + dt.timedelta(hours=2), now=now
    )
    sent_cmd = command_enqueue(vessel=vessel_b, kind="arm", params={}, expires_at=soon, now=now)
    command_claim_open(vessel=vessel_b, now=now)
    before = version(vessel_a)

    assert command_expire_due(now=soon) == 1
    assert command_expire_due(now=soon) == 0  # nothing twice

    for command in (due, later, sent_cmd):
        command.refresh_from_db()
    assert due.status == Status.EXPIRED
    assert due.finished_at == soon
    assert due.result_detail == "not delivered before expires_at"
    assert events(due) == [("", "queued"), ("queued", "expired")]
    assert later.status == Status.QUEUED
    assert sent_cmd.status == Status.SENT  # it reached the boat: no longer ours to expire
    assert version(vessel_a) == before + 1


def test_it_expires_one_vessel_only_when_asked(vessel_a: Vessel, vessel_b: Vessel) -> None:
    now = timezone.now()
    soon = now + dt.timedelta(seconds=1)
    a = command_enqueue(vessel=vessel_a, kind="arm", params={}, expires_at=soon, now=now)
    b = command_enqueue(vessel=vessel_b, kind="arm", params={}, expires_at=soon, now=now)
    assert command_expire_due(now=soon, vessel=vessel_a) == 1
    a.refresh_from_db()
    b.refresh_from_db()
    assert (a.status, b.status) == (Status.EXPIRED, Status.QUEUED)


# --- legacy delivery ---


def test_legacy_delivery_hands_out_move_to_and_hold_once(vessel_a: Vessel) -> None:
    arm = command_enqueue(vessel=vessel_a, kind="arm", params={})
    nav = move_to(vessel_a)
    delivered = command_deliver_legacy(vessel=vessel_a)
    assert [c.uid for c in delivered] == [nav.uid]
    nav.refresh_from_db()
    arm.refresh_from_db()
    assert nav.status == Status.ACKNOWLEDGED
    assert events(nav) == [("", "queued"), ("queued", "sent"), ("sent", "acknowledged")]
    assert nav.events.last().actor == "legacy"
    assert arm.status == Status.QUEUED
    assert command_deliver_legacy(vessel=vessel_a) == []


# --- one event per transition, whatever happened ---


def test_every_status_change_has_exactly_one_event(vessel_a: Vessel, glider: Vessel) -> None:
    now = timezone.now()
    move_to(vessel_a)
    move_to(vessel_a, lat=-30)
    command_enqueue(vessel=vessel_a, kind="arm", params={})
    command_claim_open(vessel=vessel_a)
    command_enqueue(
        vessel=glider, kind="hold", params={}, expires_at=now + dt.timedelta(1), now=now
    )
    command_expire_due(now=now + dt.timedelta(days=2))
    for command in Command.objects.filter(status=Status.SENT):
        command_ack(vessel=command.vessel, uid=command.uid, status="done")
    for command in Command.objects.all():
        chain = events(command)
        assert chain[0] == ("", "queued")
        assert all(a[1] == b[0] for a, b in zip(chain, chain[1:], strict=False))
        assert chain[-1][1] == command.status
        assert len(chain) == len(set(chain))
