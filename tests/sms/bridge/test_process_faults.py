"""The whole bridge under faults: a misbehaving C&C line, a misbehaving modem, ports that go
away (issue 11, Tests: faults; §10, §16 of docs/level2.md; docs/sms.md, 'The GSM modem')."""

from __future__ import annotations

import pytest

from commands.lifecycle import Status
from commands.models import Command
from sms.models import Direction, SendStatus, SmsMessage
from vessels.models import Vessel

from .rig import CONTROL, QUERY, authorise, running_bridge, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]


def commands_ended(glider: Vessel, count: int) -> bool:
    ended = Command.objects.filter(vessel=glider, status__in=[Status.DONE, Status.FAILED])
    return ended.count() >= count


@pytest.mark.parametrize(
    "faults",
    [("bad_crc", "truncated"), ("split", "escapes"), ("duplicate", "lost_reply")],
    ids=["broken-frames", "split-frames", "retries-and-duplicates"],
)
def test_a_faulty_cc_line_hands_each_sms_command_over_once(
    glider: Vessel, faults: tuple[str, ...]
) -> None:
    authorise(glider)
    with running_bridge(glider, reply_window_s=60.0) as rig:
        rig.modem.inject(CONTROL, "#LIGHT ON; #FHEAD 230; #LIGHT OFF")
        assert wait_for(lambda: Command.objects.filter(vessel=glider).count() == 3)
        sim = rig.cc(faults=faults, fault_rate=0.5, seed=11)
        for _ in range(30):
            if commands_ended(glider, 3):
                break
            sim.clock.sleep(1.0)
            sim.poll_once()
            wait_for(lambda: rig.bridge.source.in_flight is None, 1.0)
        assert wait_for(lambda: rig.modem.sent)
        assert rig.texts() == [(CONTROL, "#LIGHT ON OK; #FHEAD 230 OK; #LIGHT OFF OK")]
        assert len(sim.stats.commands) == 3
        assert sim.stats.duplicate_mismatches == 0
    for command in Command.objects.filter(vessel=glider):
        assert command.events.filter(to_status="sent").count() == 1


def test_a_cc_reset_mid_command_neither_loses_nor_repeats_it(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        rig.modem.inject(CONTROL, "#FHEAD 230")
        assert wait_for(lambda: Command.objects.filter(vessel=glider).exists())
        rig.cc(send_results=False).poll_once()  # handed over; then the C&C restarts
        sim = rig.cc()  # a new C&C enumerates again and polls
        sim.poll_once()
        assert sim.stats.commands == []  # the command in flight is not offered again
    command = Command.objects.get(vessel=glider)
    assert command.status == Status.SENT  # still waiting for its answer (or the timeout)


def test_a_slow_modem_that_errs_and_babbles_still_answers_each_sms_once(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        rig.modem.faults.delay_s = 0.1
        rig.modem.faults.garbage = True
        rig.modem.faults.send_error = 331  # no network service: temporary, retried
        rig.modem.inject(QUERY, "#FHEAD")
        assert wait_for(lambda: rig.modem.sent, 20)
        rig.modem.garbage()
        rig.modem.inject(QUERY, "#LIGHT")
        assert wait_for(lambda: len(rig.modem.sent) == 2, 20)
    assert rig.texts() == [(QUERY, "#FHEAD unknown"), (QUERY, "#LIGHT unknown")]
    assert SmsMessage.objects.filter(direction=Direction.IN).count() == 2
    assert rig.modem.store == {}


def test_a_permanent_send_error_marks_the_reply_failed_and_the_next_goes_out(
    glider: Vessel,
) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        rig.modem.faults.send_error = 305  # invalid text mode parameter: permanent (§3.2.5)
        rig.modem.inject(QUERY, "#FHEAD")
        assert wait_for(lambda: SmsMessage.objects.filter(status=SendStatus.FAILED).exists(), 20)
        rig.modem.inject(QUERY, "#LIGHT")
        assert wait_for(lambda: rig.modem.sent, 20)
    assert rig.texts() == [(QUERY, "#LIGHT unknown")]


def test_a_modem_reset_and_a_message_read_twice_are_answered_once(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider) as rig:
        index = rig.modem.inject(QUERY, "#FHEAD")
        assert index is not None
        stored = rig.modem.store[index]
        assert wait_for(lambda: rig.modem.sent, 20)
        # As if the bridge died between storing and deleting: the same delivery is still on
        # the SIM (same number, text and service centre time) when the modem resets.
        rig.modem.reset()
        rig.modem.inject(QUERY, "#FHEAD", when=stored.timestamp)
        rig.modem.inject(QUERY, "#LIGHT")
        assert wait_for(lambda: len(rig.modem.sent) >= 2 and rig.modem.store == {}, 20)
    assert rig.texts() == [(QUERY, "#FHEAD unknown"), (QUERY, "#LIGHT unknown")]
    assert SmsMessage.objects.filter(direction=Direction.IN).count() == 2


def test_a_modem_port_that_goes_away_is_reopened(glider: Vessel) -> None:
    authorise(glider)
    with running_bridge(glider, modem_where="tcp:0") as rig:
        rig.modem.inject(QUERY, "#FHEAD")
        assert wait_for(lambda: rig.modem.sent, 20)
        opens = rig.bridge.modem.opens
        rig.server.drop_client()  # the cable pulled: the driver reconnects
        rig.modem.inject(QUERY, "#LIGHT")
        assert wait_for(lambda: len(rig.modem.sent) == 2, 20)
        assert rig.bridge.modem.opens > opens
