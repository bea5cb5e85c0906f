"""The database as the payload machine's command source (sms/bridge/commands.py), driven by the
real payload machine with C&C frames (§8.4–§8.6, §10 of docs/level2.md)."""

from __future__ import annotations

import pytest

from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from commands.services import command_cancel, command_enqueue
from sms.bridge.commands import NO_ANSWER, DatabaseCommandSource
from sms.bridge.machine import BridgeMachine
from sms.level2.bodies import CommandPacket, QueuedReply, StatusReply
from sms.level2.codec import CC_COMMAND, MessageType
from sms.level2.payload import ResultWithoutCommand
from vessels.models import Vessel
from vessels.services import vessel_create

from .conftest import Clock, queued, result, status

pytestmark = pytest.mark.django_db

TIMEOUT_S = 60.0
QUARANTINE_S = 30.0


def start(glider: Vessel, clock: Clock) -> tuple[BridgeMachine, DatabaseCommandSource]:
    """A bridge (re)starting: a fresh source and machine over the same database."""
    source = DatabaseCommandSource(
        vessel=glider, result_timeout_s=TIMEOUT_S, quarantine_s=QUARANTINE_S, clock=clock
    )
    return BridgeMachine(source=source), source


def feed(machine: BridgeMachine, source: DatabaseCommandSource, frame):  # type: ignore[no-untyped-def]
    """Handle one frame as the runner does, routing unmatched results as the dispatcher does."""
    replies = machine.handle(frame)
    for note in machine.notifications():
        if isinstance(note, ResultWithoutCommand):
            source.result_without_command(note.code)
    return replies


def enqueue(glider: Vessel, kind: str, **params: object) -> Command:
    return command_enqueue(vessel=glider, kind=kind, params=params, source="admin", created_by="op")


def flagged(machine: BridgeMachine, source: DatabaseCommandSource, tid: int) -> bool:
    (reply,) = feed(machine, source, status(tid))
    return StatusReply.from_bytes(reply.body).block.queued


def handed_over(replies: list) -> bytes | None:  # type: ignore[type-arg]
    """The inner command packet in a reply to request queued, or None for the NAK."""
    (reply,) = replies
    if reply.msg_type != MessageType.ACK:
        return None
    assert reply.dest.task == CC_COMMAND.task
    return QueuedReply.from_bytes(reply.body).data[2:]


def trail(command: Command) -> list[tuple[str, str, str]]:
    return [(e.from_status, e.to_status, e.detail) for e in command.events.order_by("pk")]


def fields(command: Command, to_status: str) -> tuple[object, ...]:
    """The machine state on the command's event to ``to_status``."""
    event = command.events.get(to_status=to_status)
    return (event.cc_code, event.cc_reason, event.tid, event.src_task, event.src_board)


def test_it_counts_only_this_vessels_queued_commands(glider: Vessel, clock: Clock) -> None:
    other = vessel_create(slug="glider-2", name="Other glider", kind="wave_glider")
    enqueue(glider, "light", state="ON")
    enqueue(glider, "fhead", bearing=10)
    enqueue(other, "fhead", bearing=20)
    machine, source = start(glider, clock)
    assert source.pending_count() == 2
    assert flagged(machine, source, 0x19)


def test_a_handover_marks_the_command_sent_once_with_its_request(
    glider: Vessel, clock: Clock
) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    assert flagged(machine, source, 0x19)

    first = feed(machine, source, queued(0x1A))
    packet = handed_over(first)
    assert packet is not None
    inner = CommandPacket.from_bytes(packet)
    assert inner.value == 0x0008 and int.from_bytes(inner.params[3:5], "little") == 230
    command.refresh_from_db()
    assert command.status == Status.SENT
    # the C&C's retry (same tid, §10) is answered byte for byte, and nothing moves again
    assert feed(machine, source, queued(0x1A)) == first
    assert [t for t in trail(command) if t[1] == Status.SENT] == [
        ("queued", "sent", "handed over to the C&C in reply to request queued tid 0x001A from 0/0")
    ]
    assert fields(command, Status.SENT) == (None, "", 0x1A, 0, 0)
    assert not flagged(machine, source, 0x1B), "one command at a time: nothing flagged"


def test_an_ack_makes_it_done_through_acknowledged(glider: Vessel, clock: Clock) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    feed(machine, source, result(0, 0x1B))
    command.refresh_from_db()
    assert command.status == Status.DONE
    assert [t[:2] for t in trail(command)][-2:] == [
        ("sent", "acknowledged"),
        ("acknowledged", "done"),
    ]
    assert fields(command, Status.DONE) == (0, "", None, None, None)
    assert source.in_flight is None


def test_a_nak_fails_it_with_the_codes_meaning(glider: Vessel, clock: Clock) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    feed(machine, source, result(2, 0x1B))
    command.refresh_from_db()
    assert command.status == Status.FAILED
    assert command.result_detail == "C&C: NAK 2: invalid data"
    assert fields(command, Status.FAILED) == (2, "invalid data", None, None, None)


def test_a_command_the_table_refuses_fails_unsent_and_the_next_goes(
    glider: Vessel, clock: Clock
) -> None:
    refused = enqueue(glider, "ir", state="ON")  # provisional, not enabled
    good = enqueue(glider, "light", state="OFF")
    machine, source = start(glider, clock)
    assert handed_over(feed(machine, source, queued(0x1A))) is not None
    refused.refresh_from_db()
    good.refresh_from_db()
    assert refused.status == Status.FAILED
    assert refused.result_detail.startswith(
        "refused by the inner command table: provisional entry not enabled"
    )
    code, reason, *_ = fields(refused, Status.FAILED)
    assert code is None and str(reason).startswith("provisional entry not enabled")
    assert "not handed over" in trail(refused)[1][2]
    assert good.status == Status.SENT


def test_the_next_command_waits_for_the_answer_to_the_first(glider: Vessel, clock: Clock) -> None:
    first = enqueue(glider, "light", state="ON")
    second = enqueue(glider, "fhead", bearing=90)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    assert source.pending_count() == 0
    assert handed_over(feed(machine, source, queued(0x1C))) is None, "NAK: nothing for now"
    feed(machine, source, result(0, 0x1D))
    assert flagged(machine, source, 0x1E)
    assert handed_over(feed(machine, source, queued(0x1F))) is not None
    first.refresh_from_db()
    second.refresh_from_db()
    assert (first.status, second.status) == (Status.DONE, Status.SENT)


def test_no_answer_fails_it_and_a_late_answer_is_never_credited_to_the_next(
    glider: Vessel, clock: Clock
) -> None:
    a = enqueue(glider, "light", state="ON")
    b = enqueue(glider, "fhead", bearing=90)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    clock.advance(TIMEOUT_S - 1)
    assert not source.expire_overdue()
    clock.advance(2)
    assert source.expire_overdue()
    a.refresh_from_db()
    assert (a.status, a.result_detail) == (Status.FAILED, NO_ANSWER)
    assert fields(a, Status.FAILED) == (None, "", None, None, None)  # the C&C never answered

    # quarantine: B is not offered, and A's late answer is logged on A, credited to nobody
    assert not flagged(machine, source, 0x20)
    feed(machine, source, result(0, 0x21))
    b.refresh_from_db()
    assert b.status == Status.QUEUED
    assert trail(a)[-1][2] == "late answer from the C&C after the timeout, not credited: ACK"
    assert source.late_results == 1

    clock.advance(QUARANTINE_S)
    assert flagged(machine, source, 0x22)
    feed(machine, source, queued(0x23))
    feed(machine, source, result(3, 0x24))
    a.refresh_from_db()
    b.refresh_from_db()
    assert a.status == Status.FAILED and b.status == Status.FAILED
    assert b.result_detail == "C&C: NAK 3: unable to complete"


def test_after_a_timeout_with_no_late_answer_the_next_answer_is_the_next_commands(
    glider: Vessel, clock: Clock
) -> None:
    a = enqueue(glider, "light", state="ON")
    b = enqueue(glider, "fhead", bearing=90)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    clock.advance(TIMEOUT_S + QUARANTINE_S + 1)
    source.expire_overdue()
    clock.advance(QUARANTINE_S + 1)
    feed(machine, source, queued(0x30))
    # the machine still remembers A first; the source credits the command in flight: B
    assert machine.awaiting_result[0] == str(a.uid)
    feed(machine, source, result(0, 0x31))
    b.refresh_from_db()
    assert b.status == Status.DONE


def test_a_restart_after_the_handover_answers_the_retry_identically(
    glider: Vessel, clock: Clock
) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    enqueue(glider, "light", state="ON")
    machine, source = start(glider, clock)
    before = feed(machine, source, queued(0x1A))

    clock.advance(2)  # killed, restarted; the C&C retries the same request (§10)
    machine, source = start(glider, clock)
    assert feed(machine, source, queued(0x1A)) == before
    command.refresh_from_db()
    sent_events = [t for t in trail(command) if t[:2] == ("queued", "sent")]
    assert len(sent_events) == 1
    assert "answered again" in trail(command)[-1][2]

    # the answer reaches a machine that never saw the handover: still credited
    feed(machine, source, result(0, 0x1B))
    command.refresh_from_db()
    assert command.status == Status.DONE


def test_a_restart_reads_the_request_from_the_sent_events_fields_not_its_detail(
    glider: Vessel, clock: Clock
) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    before = feed(machine, source, queued(0x1A))
    # the detail is for people: rewording it must not change what a restart answers
    CommandEvent.objects.filter(command=command, to_status=Status.SENT).update(detail="sent")
    clock.advance(2)
    machine, source = start(glider, clock)
    assert feed(machine, source, queued(0x1A)) == before


def test_after_a_restart_a_new_request_takes_nothing_while_one_is_in_flight(
    glider: Vessel, clock: Clock
) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    other = enqueue(glider, "light", state="ON")
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    machine, source = start(glider, clock)
    assert handed_over(feed(machine, source, queued(0x40))) is None
    clock.advance(TIMEOUT_S + 1)
    assert source.expire_overdue(), "the timeout runs from sent_at, across the restart"
    command.refresh_from_db()
    other.refresh_from_db()
    assert (command.status, other.status) == (Status.FAILED, Status.QUEUED)


def test_a_retry_after_the_window_or_a_new_enumeration_takes_nothing(
    glider: Vessel, clock: Clock
) -> None:
    enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    machine, source = start(glider, clock)
    source.forget_request_ids()  # the C&C enumerated: its counter restarted
    assert handed_over(feed(machine, source, queued(0x1A))) is None
    machine, source = start(glider, clock)
    clock.advance(30)
    assert handed_over(feed(machine, source, queued(0x1A))) is None


def test_a_restart_between_the_flag_and_the_handover_loses_nothing(
    glider: Vessel, clock: Clock
) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    assert flagged(machine, source, 0x19)
    machine, source = start(glider, clock)
    assert handed_over(feed(machine, source, queued(0x1A))) is not None
    command.refresh_from_db()
    assert command.status == Status.SENT


def test_an_answer_after_an_operator_cancelled_is_noted_not_applied(
    glider: Vessel, clock: Clock
) -> None:
    command = enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    command_cancel(command=command, actor="op")
    feed(machine, source, result(0, 0x1B))
    command.refresh_from_db()
    assert command.status == Status.CANCELLED
    assert trail(command)[-1][2] == "the C&C answered ACK after the command became cancelled"


def test_expired_and_cancelled_commands_are_never_handed_over(glider: Vessel, clock: Clock) -> None:
    import datetime as dt

    expiring = command_enqueue(
        vessel=glider,
        kind="light",
        params={"state": "ON"},
        expires_at=clock.now + dt.timedelta(seconds=5),
        now=clock.now,
    )
    cancelled = enqueue(glider, "waypoint", index=1, lat=-32.0, lon=115.5)
    command_cancel(command=cancelled, actor="op")
    machine, source = start(glider, clock)
    clock.advance(10)
    assert source.pending_count() == 0
    assert handed_over(feed(machine, source, queued(0x1A))) is None
    source.expire_overdue()  # the bridge loop's sweep
    expiring.refresh_from_db()
    assert expiring.status == Status.EXPIRED


def test_a_result_the_database_refuses_is_kept_and_written_by_flush_results(
    glider: Vessel, clock: Clock, monkeypatch: pytest.MonkeyPatch
) -> None:
    from django.db import OperationalError

    from sms.bridge import commands as module

    def locked(**_kw: object) -> bool:
        raise OperationalError("database is locked")

    command = enqueue(glider, "fhead", bearing=230)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    monkeypatch.setattr(module, "command_complete", locked)
    feed(machine, source, result(0, 0x1B))  # the machine's reply path does not crash
    assert source.flush_results() == 1
    monkeypatch.undo()
    assert source.flush_results() == 0
    command.refresh_from_db()
    assert command.status == Status.DONE


def test_the_hot_count_goes_through_the_open_commands_index(glider: Vessel, clock: Clock) -> None:
    enqueue(glider, "light", state="ON")
    _machine, source = start(glider, clock)
    assert source.pending_count() == 1
    assert not source._indexed_query_failed


def test_without_that_index_the_orm_counts_and_nothing_goes_silent(
    glider: Vessel, clock: Clock, monkeypatch: pytest.MonkeyPatch
) -> None:
    from django.db import connection

    from sms import sql

    if connection.vendor != "sqlite":
        pytest.skip("INDEXED BY is SQLite's")
    enqueue(glider, "light", state="ON")
    monkeypatch.setattr(sql, "OPEN_INDEX", "no_such_index")
    machine, source = start(glider, clock)
    assert source.pending_count() == 1 and source._indexed_query_failed
    assert handed_over(feed(machine, source, queued(0x1A))) is not None


def test_a_quarantine_survives_a_restart(glider: Vessel, clock: Clock) -> None:
    a = enqueue(glider, "light", state="ON")
    b = enqueue(glider, "fhead", bearing=90)
    machine, source = start(glider, clock)
    feed(machine, source, queued(0x1A))
    clock.advance(TIMEOUT_S + 1)
    source.expire_overdue()
    clock.advance(5)
    machine, source = start(glider, clock)  # restarted within the quarantine
    assert source.pending_count() == 0
    feed(machine, source, result(0, 0x21))  # A's late answer
    b.refresh_from_db()
    assert b.status == Status.QUEUED
    assert trail(a)[-1][2].startswith("late answer from the C&C after the timeout")
    clock.advance(QUARANTINE_S)
    machine, source = start(glider, clock)
    assert source.pending_count() == 1


@pytest.mark.parametrize(
    ("kind", "params"),
    [
        ("fhead", {"bearing": 0}),
        ("light", {"state": "OFF"}),
        ("waypoint", {"index": 254, "lat": -32.0, "lon": 115.5}),
        ("hold", {}),
    ],
)
def test_every_sourced_kind_goes_out_as_the_services_stored_it(
    glider: Vessel, clock: Clock, kind: str, params: dict[str, object]
) -> None:
    command = enqueue(glider, kind, **params)
    machine, source = start(glider, clock)
    assert handed_over(feed(machine, source, queued(0x1A))) is not None
    command.refresh_from_db()
    assert command.status == Status.SENT
