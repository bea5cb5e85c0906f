"""The payload machine's notifications routed to the bridge's parts (sms/bridge/dispatch.py)."""

from __future__ import annotations

import datetime as dt
import logging

import pytest

from commands.lifecycle import Status
from commands.services import command_enqueue
from sms.bridge.commands import DatabaseCommandSource
from sms.bridge.dispatch import Dispatcher
from sms.bridge.fixes import FixRecorder
from sms.bridge.machine import BridgeMachine
from sms.level2.bodies import Enumerate
from sms.level2.codec import BROADCAST, CC_MAIN, Frame, MessageType
from telemetry.models import Fix
from vessels.models import Vessel

from .conftest import Clock, queued, result, status

pytestmark = pytest.mark.django_db


def bridge(glider: Vessel, clock: Clock) -> tuple[BridgeMachine, Dispatcher]:
    source = DatabaseCommandSource(vessel=glider, clock=clock)
    machine = BridgeMachine(source=source)
    fixes = FixRecorder(vessel=glider, readings=lambda: {"pressure_kpa": 100.0})
    return machine, Dispatcher(machine=machine, source=source, fixes=fixes)


def run(machine: BridgeMachine, dispatch: Dispatcher, frame: Frame) -> list[Frame]:
    replies = machine.handle(frame)
    for note in machine.notifications():
        dispatch(note)
    return replies


def test_status_requests_become_fixes(glider: Vessel, clock: Clock) -> None:
    machine, dispatch = bridge(glider, clock)
    when = clock.now.replace(microsecond=0)
    run(machine, dispatch, status(0x19, (when, 36.80278, -121.78812)))
    run(machine, dispatch, status(0x1A, (when, 36.80278, -121.78812)))  # same C&C time
    run(machine, dispatch, status(0x1B))  # the no-fix form (§8.3)
    run(machine, dispatch, status(0x1C, (when + dt.timedelta(seconds=20), 36.81, -121.79)))
    dispatch.fixes.flush()
    fixes = list(Fix.objects.filter(vessel=glider).order_by("recorded_at"))
    assert [f.recorded_at for f in fixes] == [when, when + dt.timedelta(seconds=20)]
    assert fixes[0].lat == pytest.approx(36.80278, abs=1e-5)
    assert fixes[0].readings == {"pressure_kpa": 100.0}


def test_a_result_after_a_restart_reaches_the_command(glider: Vessel, clock: Clock) -> None:
    command = command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230})
    machine, dispatch = bridge(glider, clock)
    run(machine, dispatch, queued(0x1A))
    machine, dispatch = bridge(glider, clock)
    run(machine, dispatch, result(2, 0x1B))
    command.refresh_from_db()
    assert (command.status, command.result_detail) == (Status.FAILED, "C&C: NAK 2: invalid data")


def test_a_new_enumeration_makes_an_old_tid_a_new_request(glider: Vessel, clock: Clock) -> None:
    command_enqueue(vessel=glider, kind="fhead", params={"bearing": 230})
    machine, dispatch = bridge(glider, clock)
    run(machine, dispatch, queued(0x1A))
    machine, dispatch = bridge(glider, clock)
    run(
        machine,
        dispatch,
        Frame.make(
            MessageType.ENUMERATE, bytes(Enumerate()), tid=0x17, dest=BROADCAST, src=CC_MAIN
        ),
    )
    (nak,) = run(machine, dispatch, queued(0x1A))
    assert nak.msg_type == MessageType.NAK


def test_a_power_down_notice_flushes_the_fixes_and_logs_the_frame(
    glider: Vessel, clock: Clock, caplog: pytest.LogCaptureFixture
) -> None:
    machine, dispatch = bridge(glider, clock)
    run(machine, dispatch, status(0x19, (clock.now.replace(microsecond=0), 36.8, -121.8)))
    notice = Frame.make(MessageType.POWER, b"\x01\x00", tid=0x30, dest=BROADCAST, src=CC_MAIN)
    caplog.set_level(logging.WARNING, "sms.bridge.power")
    assert run(machine, dispatch, notice) == []
    (outcome,) = dispatch.power_downs
    assert outcome.flushed == ["fixes", "command results"]
    assert Fix.objects.filter(vessel=glider).count() == 1
    assert bytes(notice).hex(" ") in caplog.text


def test_a_failing_handler_is_logged_and_the_link_goes_on(
    glider: Vessel, clock: Clock, monkeypatch: pytest.MonkeyPatch
) -> None:
    machine, dispatch = bridge(glider, clock)

    def broken(_fix: object) -> bool:
        raise RuntimeError("boom")

    monkeypatch.setattr(dispatch.fixes, "record", broken)
    run(machine, dispatch, status(0x19, (clock.now.replace(microsecond=0), 36.8, -121.8)))
    assert dispatch.errors == 1
    (reply,) = run(machine, dispatch, status(0x1A))
    assert reply.msg_type == MessageType.ACK


def test_a_repeated_power_down_notice_is_acted_on_once_a_minute(
    glider: Vessel, clock: Clock
) -> None:
    machine, dispatch = bridge(glider, clock)
    now = [0.0]
    dispatch.clock = lambda: now[0]
    for tid in (0x30, 0x31):
        notice = Frame.make(MessageType.POWER, b"\x01\x00", tid=tid, dest=BROADCAST, src=CC_MAIN)
        run(machine, dispatch, notice)
    assert len(dispatch.power_downs) == 1
    now[0] += 61
    run(
        machine,
        dispatch,
        Frame.make(MessageType.POWER, b"\x01", tid=0x32, dest=BROADCAST, src=CC_MAIN),
    )
    assert len(dispatch.power_downs) == 2
