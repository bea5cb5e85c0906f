"""The glider's position by SMS (issue 20 §5): the reporter on the real database with a fake
clock, then the whole bridge on pseudo-terminals, the modem simulator taking the SMS."""

from __future__ import annotations

import datetime as dt
import logging

import pytest

from commands.lifecycle import Status
from commands.services import command_enqueue
from sms.bridge.position_schedule import slot_start
from sms.bridge.positions import PositionReporter
from sms.gsm7 import SMS_SEPTETS, is_gsm7, septets
from sms.models import AuthorisedNumber, Direction, SendStatus, SmsMessage
from sms.services import authorised_number_authorise, authorised_number_deauthorise
from telemetry.services import fix_ingest
from vessels.models import Vessel

from .conftest import Clock
from .rig import CONTROL, QUERY, authorise, running_bridge, wait_for

PERIOD = 600.0
WATCHER = "+61400000003"


def positions(glider: Vessel) -> list[SmsMessage]:
    return list(
        SmsMessage.objects.filter(
            vessel=glider, direction=Direction.OUT, delivery_key__startswith="pos:"
        ).order_by("pk")
    )


def receive_positions(glider: Vessel, number: str, role: str = "query") -> AuthorisedNumber:
    return authorised_number_authorise(
        number=number, vessels=[glider], role=role, name=number[-3:], receives_positions=True
    )


def add_fix(glider: Vessel, when: dt.datetime, **values: object) -> None:
    record = {"time": when.isoformat(), "lat": 36.803, "lon": -121.788, **values}
    assert fix_ingest(vessel=glider, records=[record], now=when).accepted == 1


def next_slot(clock: Clock) -> dt.datetime:
    return slot_start(clock(), PERIOD) + dt.timedelta(seconds=PERIOD)


# -- the reporter and the database, no threads ---------------------------------------------------


@pytest.mark.django_db
def test_rounds_go_to_the_flagged_active_numbers_once_per_fix(
    glider: Vessel, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "sms.bridge.positions")
    clock = Clock(dt.datetime.now(dt.UTC) - dt.timedelta(hours=3))
    authorise(glider)  # CONTROL and QUERY: not flagged
    receive_positions(glider, WATCHER)
    gone = receive_positions(glider, "+61400000004")
    authorised_number_deauthorise(entry=gone)
    expired = receive_positions(glider, "+61400000005")
    AuthorisedNumber.objects.filter(pk=expired.pk).update(expires_at=clock() - dt.timedelta(days=1))
    add_fix(glider, clock() - dt.timedelta(seconds=30), heading_deg=230.0, battery_v=12.6)
    nudges: list[int] = []
    reporter = PositionReporter(
        vessel=glider, period_s=PERIOD, now=clock, hold_s=0, nudge=lambda: nudges.append(1)
    )
    assert reporter.do_one() is False  # a first start waits for the next slot
    clock.now = next_slot(clock)
    assert reporter.do_one() is True and nudges == [1]
    (sms,) = positions(glider)
    assert (sms.number, sms.status, sms.authorised) == (WATCHER, SendStatus.PENDING, True)
    assert "36.80300,-121.78800 hdg 230 batt 12.6V" in sms.text
    assert sms.text.startswith("Wave Glider ") and sms.parsed[0]["position"]
    # The next slot without a newer fix: nothing, said once.
    clock.advance(PERIOD)
    assert reporter.do_one() is False and reporter.do_one() is False
    assert caplog.text.count("no fix newer than") == 1
    add_fix(glider, clock() - dt.timedelta(seconds=5))
    assert reporter.do_one() is True
    assert len(positions(glider)) == 2


@pytest.mark.django_db
def test_a_restart_picks_up_the_schedule_from_the_sms_log(glider: Vessel) -> None:
    clock = Clock(dt.datetime.now(dt.UTC) - dt.timedelta(hours=3))
    receive_positions(glider, WATCHER)
    add_fix(glider, clock() - dt.timedelta(seconds=30))
    first = PositionReporter(vessel=glider, period_s=PERIOD, now=clock, hold_s=0)
    assert first.do_one() is False
    clock.now = next_slot(clock)
    assert first.do_one() is True
    # Restarted in the same slot with a newer fix: no round at start-up.
    clock.advance(60)
    add_fix(glider, clock() - dt.timedelta(seconds=10))
    again = PositionReporter(vessel=glider, period_s=PERIOD, now=clock, hold_s=0)
    assert again.do_one() is False and len(positions(glider)) == 1
    clock.now = next_slot(clock)
    assert again.do_one() is True and len(positions(glider)) == 2
    # Restarted after missing slots with no newer fix: nothing (the log knows the fix sent).
    clock.advance(PERIOD * 5)
    third = PositionReporter(vessel=glider, period_s=PERIOD, now=clock, hold_s=0)
    assert third.do_one() is False and len(positions(glider)) == 2


@pytest.mark.django_db
def test_nobody_to_tell_is_logged_once_and_a_number_never_gets_a_fix_twice(
    glider: Vessel, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "sms.bridge.positions")
    clock = Clock(dt.datetime.now(dt.UTC) - dt.timedelta(hours=3))
    reporter = PositionReporter(vessel=glider, period_s=PERIOD, now=clock, hold_s=0)
    reporter.do_one()
    for minute in range(3):
        add_fix(glider, clock() + dt.timedelta(minutes=minute))
        clock.now = next_slot(clock)
        assert reporter.do_one() is False
    assert caplog.text.count("no authorised number receives positions") == 1
    receive_positions(glider, WATCHER)
    # The same fix once more (a schedule that forgot it): the log's key lets it in once.
    add_fix(glider, clock() + dt.timedelta(minutes=5))
    for _ in range(2):
        reporter.schedule.last_fix_at = None  # type: ignore[union-attr]
        clock.now = next_slot(clock)
        reporter.do_one()
    assert len(positions(glider)) == 1


# -- the whole bridge: the C&C simulator, the modem simulator --------------------------------------


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_the_bridge_texts_its_position_on_schedule_through_the_modem(
    glider: Vessel, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.INFO, "sms.bridge.positions")
    authorise(glider)
    receive_positions(glider, CONTROL, role="control")  # QUERY does not receive positions
    clock = Clock(dt.datetime.now(dt.UTC))
    options = {"now": clock, "hold_s": 0}
    config = {"position_sms_period_s": PERIOD}
    with running_bridge(glider, position_options=options, **config) as rig:
        command = command_enqueue(
            vessel=glider, kind="fhead", params={"bearing": 230}, source="sms", created_by=CONTROL
        )
        sim = rig.cc()
        for _ in range(3):
            sim.clock.sleep(1.0)
            sim.poll_once()
        assert wait_for(lambda: rig.bridge.fixes.received >= 1)

        def done() -> bool:
            command.refresh_from_db()
            return command.status == Status.DONE

        assert wait_for(done)
        assert not wait_for(lambda: rig.modem.sent, timeout_s=0.5)  # first start: next slot
        clock.now = next_slot(clock)
        assert wait_for(lambda: rig.modem.sent)
        ((number, text),) = rig.texts()
        assert number == CONTROL and is_gsm7(text) and septets(text) <= SMS_SEPTETS
        assert text.startswith("Wave Glider 20") and " UTC 36.80300,-121.78800" in text
        assert text.endswith("nav #FHEAD 230")  # the C&C took it: its state as the bridge knows
        (logged,) = positions(glider)
        assert wait_for(lambda: SmsMessage.objects.get(pk=logged.pk).status == SendStatus.SENT)
        assert SmsMessage.objects.get(pk=logged.pk).reference  # the modem's +CMGS reference

        # The next slot, the C&C silent: no SMS, and the log says so once.
        clock.now = next_slot(clock)
        assert not wait_for(lambda: len(rig.modem.sent) > 1, timeout_s=0.5)
        assert caplog.text.count("no fix newer than") == 1
        # A new fix: the round goes out at once.
        for _ in range(2):
            sim.clock.sleep(1.0)
            sim.poll_once()
        assert wait_for(lambda: len(rig.modem.sent) == 2)
        assert [n for n, _ in rig.texts()] == [CONTROL, CONTROL]
        first, second = positions(glider)
        assert first.parsed[0]["position"] < second.parsed[0]["position"]

    # A restart in the same slot, with a new fix: no SMS at start-up; the next slot's goes.
    clock.advance(1)
    with running_bridge(glider, position_options=options, **config) as rig:
        later = dt.datetime.now(dt.UTC).replace(microsecond=0) + dt.timedelta(minutes=1)
        sim = rig.cc(start_time=later)  # the C&C's GPS time: past the last fix sent
        for _ in range(2):
            sim.clock.sleep(1.0)
            sim.poll_once()
        assert wait_for(lambda: rig.bridge.fixes.received >= 1)
        assert not wait_for(lambda: rig.modem.sent, timeout_s=1.0)
        clock.now = next_slot(clock)
        assert wait_for(lambda: len(rig.modem.sent) == 1)
    assert len(positions(glider)) == 3
    assert QUERY not in {m.number for m in positions(glider)}
