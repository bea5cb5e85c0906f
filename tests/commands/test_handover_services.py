"""The services for transports that hand commands over one at a time (the Wave Glider bridge):
mark sent, fail unsent, complete, note."""

from __future__ import annotations

import pytest

from commands.lifecycle import Status
from commands.models import Command
from commands.services import (
    CommandError,
    command_cancel,
    command_complete,
    command_enqueue,
    command_fail_unsent,
    command_mark_sent,
    command_note,
)
from vessels.models import Vessel

pytestmark = pytest.mark.django_db


def fhead(glider: Vessel) -> Command:
    return command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230})


def steps(command: Command) -> list[tuple[str, str]]:
    return [(e.from_status, e.to_status) for e in command.events.order_by("pk")]


def test_mark_sent_wins_once(glider: Vessel) -> None:
    command = fhead(glider)
    stale = Command.objects.get(pk=command.pk)
    assert command_mark_sent(command=command, actor="wg-bridge", detail="tid 0x001A")
    assert not command_mark_sent(command=stale, actor="wg-bridge")
    command.refresh_from_db()
    assert command.status == Status.SENT and command.sent_at is not None
    assert command.events.last().detail == "tid 0x001A"


def test_mark_sent_loses_to_a_cancel(glider: Vessel) -> None:
    command = fhead(glider)
    stale = Command.objects.get(pk=command.pk)
    command_cancel(command=command, actor="op")
    assert not command_mark_sent(command=stale, actor="wg-bridge")
    stale.refresh_from_db()
    assert stale.status == Status.CANCELLED


def test_fail_unsent_records_the_reason_and_that_nothing_was_handed_over(glider: Vessel) -> None:
    command = fhead(glider)
    assert command_fail_unsent(command=command, reason="refused: bad params", actor="wg-bridge")
    command.refresh_from_db()
    assert (command.status, command.result_detail) == (Status.FAILED, "refused: bad params")
    assert steps(command) == [("", "queued"), ("queued", "sent"), ("sent", "failed")]
    assert command.events.order_by("pk")[1].detail == "not handed over: refused: bad params"


def test_complete_done_passes_through_acknowledged(glider: Vessel) -> None:
    command = fhead(glider)
    command_mark_sent(command=command, actor="wg-bridge")
    assert command_complete(command=command, status="done", detail="ACK", actor="wg-bridge")
    command.refresh_from_db()
    assert command.status == Status.DONE
    assert steps(command)[-2:] == [("sent", "acknowledged"), ("acknowledged", "done")]
    assert command.acknowledged_at is not None and command.finished_at is not None


def test_complete_failed_goes_straight_to_failed(glider: Vessel) -> None:
    command = fhead(glider)
    command_mark_sent(command=command, actor="wg-bridge")
    assert command_complete(command=command, status="failed", detail="NAK", actor="wg-bridge")
    command.refresh_from_db()
    assert steps(command)[-1] == ("sent", "failed")
    assert command.result_detail == "NAK"


def test_complete_changes_nothing_on_an_ended_command(glider: Vessel) -> None:
    command = fhead(glider)
    command_mark_sent(command=command, actor="wg-bridge")
    command_cancel(command=Command.objects.get(pk=command.pk), actor="op")
    assert not command_complete(command=command, status="done", detail="ACK", actor="wg-bridge")
    command.refresh_from_db()
    assert command.status == Status.CANCELLED


def test_complete_takes_only_done_or_failed(glider: Vessel) -> None:
    command = fhead(glider)
    with pytest.raises(CommandError):
        command_complete(command=command, status="acknowledged", detail="", actor="x")


def test_a_note_keeps_the_status(glider: Vessel) -> None:
    command = fhead(glider)
    event = command_note(command=command, detail="late answer\x00", actor="wg-bridge")
    assert (event.from_status, event.to_status) == ("queued", "queued")
    assert event.detail == "late answer\ufffd"
    command.refresh_from_db()
    assert command.status == Status.QUEUED


def answers(command: Command) -> list[tuple[str, int | None, str, int | None]]:
    """Each event's machine state: (to_status, cc_code, cc_reason, tid)."""
    return list(
        command.events.order_by("pk").values_list("to_status", "cc_code", "cc_reason", "tid")
    )


def test_the_answer_and_the_request_go_on_the_events_they_belong_to(glider: Vessel) -> None:
    # not navigation commands: a newer one would supersede the older ones
    done, failed, refused = (
        command_enqueue(vessel=glider, kind="light", params={"state": state})
        for state in ("ON", "OFF", "ON")
    )
    for command, tid in ((done, 0x1A), (failed, 0x1C)):
        command_mark_sent(command=command, actor="wg-bridge", tid=tid, src_task=0, src_board=0)
    command_complete(command=done, status="done", detail="ACK", actor="wg-bridge", cc_code=0)
    command_complete(
        command=failed,
        status="failed",
        detail="NAK",
        actor="wg-bridge",
        cc_code=2,
        cc_reason="invalid data\x00",
    )
    command_fail_unsent(command=refused, reason="no", actor="wg-bridge", cc_reason="bad params")
    assert answers(done)[1:] == [
        ("sent", None, "", 0x1A),
        ("acknowledged", 0, "", None),  # one ACK both accepts and completes it
        ("done", 0, "", None),
    ]
    assert answers(failed)[1:] == [
        ("sent", None, "", 0x1C),
        ("failed", 2, "invalid data\ufffd", None),
    ]
    assert answers(refused)[1:] == [("sent", None, "", None), ("failed", None, "bad params", None)]
