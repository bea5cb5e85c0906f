"""The whole bridge through real serial plumbing: the modem simulator and the C&C simulator on
pseudo-terminals, the bridge's own threads in between (issue 11, Tests: end to end)."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from commands.lifecycle import Status
from commands.models import Command
from sms.bridge.records import RecordTable
from sms.bridge.sensor_standin import CAPTURED, RecordServer
from sms.level2.bodies import StatusReply
from sms.level2.codec import BROADCAST, CC_MAIN, Frame, MessageType
from sms.level2.runner import SerialLink
from sms.models import Direction, Outcome, SendStatus, SmsMessage
from telemetry.models import Fix
from vessels.models import Vessel

from .conftest import status
from .rig import CONTROL, QUERY, STRANGER, authorise, running_bridge, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]


def queued_commands(glider: Vessel, count: int = 1) -> bool:
    return Command.objects.filter(vessel=glider).count() >= count


def test_fhead_230_by_sms_reaches_the_cc_and_the_phone_gets_ok(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        rig.modem.inject(CONTROL, "#FHEAD 230")
        assert wait_for(lambda: queued_commands(glider))
        sim = rig.cc()
        sim.poll_once()
        (packet,) = sim.stats.commands
        assert packet.value == 0x0008 and int.from_bytes(packet.params[3:5], "little") == 230
        assert wait_for(lambda: rig.modem.sent)
        assert rig.texts() == [(CONTROL, "#FHEAD 230 OK")]
        assert rig.modem.store == {}  # deleted once stored
    command = Command.objects.get(vessel=glider)
    assert command.status == Status.DONE
    incoming = SmsMessage.objects.get(direction=Direction.IN)
    reply = SmsMessage.objects.get(direction=Direction.OUT)
    assert (reply.status, reply.reply_to_id) == (SendStatus.SENT, incoming.pk)
    assert list(incoming.commands.all()) == list(reply.commands.all()) == [command]


def test_a_nak_is_told_to_the_sender_with_its_meaning(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        rig.modem.inject(CONTROL, "#FHEAD 230")
        assert wait_for(lambda: queued_commands(glider))
        rig.cc(ack_policy=lambda _i, _p: 2).poll_once()
        assert wait_for(lambda: rig.modem.sent)
        assert rig.texts() == [(CONTROL, "#FHEAD 230 FAILED invalid data")]
    assert Command.objects.get(vessel=glider).status == Status.FAILED


def test_queries_are_answered_at_once_and_status_gives_the_position(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        sim = rig.cc()
        sim.poll_once()
        sim.poll_once()  # every other status request carries the position (§8.3, docs/level2.md)
        assert wait_for(lambda: rig.bridge.fixes.pending)  # held for its batch; an SMS flushes it
        rig.modem.inject(QUERY, "#FHEAD")
        rig.modem.inject(QUERY, "#STATUS")
        assert wait_for(lambda: len(rig.modem.sent) == 2)
        texts = dict(rig.texts()[:1]), rig.texts()[1][1]
    assert texts[0] == {QUERY: "#FHEAD unknown"}
    assert texts[1].startswith("#STATUS pos 36.8030 -121.7880")


def test_a_stranger_is_logged_and_never_answered(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        rig.modem.inject(STRANGER, "#FHEAD 230")
        rig.modem.inject(CONTROL, "#FHEAD")
        assert wait_for(lambda: rig.modem.sent)  # the second SMS is answered: the first was read
        assert rig.texts() == [(CONTROL, "#FHEAD unknown")]
    stranger = SmsMessage.objects.get(number_e164=STRANGER)
    assert stranger.outcome == Outcome.STRANGER
    assert not Command.objects.filter(vessel=glider).exists()


def test_three_commands_in_one_sms_get_one_reply_once_all_have_ended(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider, reply_window_s=30.0) as rig:
        rig.modem.inject(CONTROL, "#LIGHT ON; #FHEAD 230; #LIGHT OFF")
        assert wait_for(lambda: queued_commands(glider, 3))
        sim = rig.cc(ack_policy=lambda index, _p: 2 if index == 1 else 0)
        for _ in range(3):  # one command in flight at a time: one per poll
            sim.poll_once()
            assert wait_for(lambda: rig.bridge.source.in_flight is None)
        assert len(sim.stats.commands) == 3
        assert wait_for(lambda: rig.modem.sent)
        assert rig.texts() == [
            (CONTROL, "#LIGHT ON OK; #FHEAD 230 FAILED invalid data; #LIGHT OFF OK")
        ]


def test_a_result_that_never_comes_is_queued_then_told_when_it_fails(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider, reply_window_s=0.5, result_timeout_s=1.5) as rig:
        rig.modem.inject(CONTROL, "#FHEAD 230")
        assert wait_for(lambda: queued_commands(glider))
        rig.cc(send_results=False).poll_once()
        assert wait_for(lambda: len(rig.modem.sent) == 2)
        assert rig.texts() == [
            (CONTROL, "#FHEAD 230 QUEUED"),
            (CONTROL, "#FHEAD 230 FAILED no answer from the C&C box"),
        ]
    assert SmsMessage.objects.filter(direction=Direction.OUT, status=SendStatus.SENT).count() == 2


def test_status_gives_the_boards_readings_and_the_cc_gets_them_too(glider: Vessel) -> None:
    stasis = RecordTable.load().records["stasis"]
    board = RecordServer(stasis, lambda: CAPTURED, port=0, period_s=0.05).start()
    authorise(glider)
    try:
        with running_bridge(
            glider, sensor_host="127.0.0.1", sensor_ports={"stasis": board.port}
        ) as rig:
            assert wait_for(lambda: rig.bridge.readings.snapshot())
            rig.modem.inject(QUERY, "#STATUS")
            assert wait_for(lambda: rig.modem.sent)
            link = SerialLink(rig.cc_port)
            link.send(bytes(status(0x50)))
            reply = link.receive(2.0)
    finally:
        board.stop()
    assert rig.texts()[0][1].endswith("0 pending, 21.0C 35%RH 100.0kPa leak 0/0")
    assert reply is not None
    assert StatusReply.from_bytes(reply.body).block.pressure_kpa == 100


def test_a_loop_such_as_the_shore_link_runs_in_its_own_thread_until_the_stop(
    glider: Vessel,
) -> None:
    seen: list[str] = []

    def shore(stop: threading.Event) -> None:
        seen.append(threading.current_thread().name)
        stop.wait()
        seen.append("stopped")

    with running_bridge(glider, loops=[("shore", shore)]) as rig:
        assert wait_for(lambda: seen)
        assert rig.thread.is_alive()
    assert seen == ["wg-shore", "stopped"]


def test_a_clean_stop_writes_the_fixes_it_held(glider: Vessel) -> None:
    with running_bridge(glider) as rig:
        sim = rig.cc()
        sim.poll_once()
        sim.poll_once()  # a fix, held in memory for its batch
        assert wait_for(lambda: rig.bridge.fixes.pending)
        assert not Fix.objects.filter(vessel=glider).exists()
    assert Fix.objects.filter(vessel=glider).count() == 1


def test_a_power_down_notice_runs_the_configured_command(glider: Vessel, tmp_path: Path) -> None:
    marker = tmp_path / "powered-down"
    with running_bridge(glider, power_command=f"touch {marker}") as rig:
        notice = Frame.make(MessageType.POWER, b"\x01\x00", tid=0x30, dest=BROADCAST, src=CC_MAIN)
        SerialLink(rig.cc_port).send(bytes(notice))
        assert wait_for(marker.exists)
    (outcome,) = rig.bridge.dispatch.power_downs
    assert outcome.returncode == 0 and "fixes" in outcome.flushed
