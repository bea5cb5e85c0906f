"""The position SMS's schedule (issue 20 §5), pure, on a fake clock."""

from __future__ import annotations

import datetime as dt

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sms.bridge.position_schedule import (
    MIN_PERIOD_S,
    Action,
    PositionSchedule,
    check_period,
    slot_start,
)

from .conftest import Clock

HOUR = 3600.0
START = dt.datetime(2026, 11, 28, 11, 20, 7, tzinfo=dt.UTC)


def at(hh: int, mm: int, ss: int = 0) -> dt.datetime:
    return START.replace(hour=hh, minute=mm, second=ss)


def test_off_when_the_period_is_zero() -> None:
    schedule = PositionSchedule(period_s=0, started_at=START)
    assert schedule.check(at(23, 0), at(22, 59)).action == Action.OFF
    assert not schedule.is_due(at(23, 0))


@pytest.mark.parametrize("period", [1.0, 59.9, -60.0, float("nan"), float("inf")])
def test_a_period_below_a_minute_is_refused(period: float) -> None:
    with pytest.raises(ValueError, match="0 \\(off\\) or at least 60"):
        check_period(period)
    check_period(MIN_PERIOD_S)


def test_slots_are_counted_from_the_epoch() -> None:
    assert slot_start(at(11, 20, 7), HOUR) == at(11, 0)
    assert slot_start(at(11, 20, 7), 600) == at(11, 20)


def test_a_first_start_waits_for_the_next_slot_then_sends_each_new_fix_once_per_slot() -> None:
    clock = Clock(START)
    schedule = PositionSchedule(period_s=HOUR, started_at=clock())
    fix = at(11, 19)
    decision = schedule.check(clock(), fix)
    assert (decision.action, decision.due_at) == (Action.WAIT, at(12, 0))
    clock.advance(40 * 60)  # 12:00:07
    assert schedule.check(clock(), fix).action == Action.SEND
    schedule.sent(clock(), fix)
    newer = at(12, 1)
    assert schedule.check(clock(), newer).action == Action.WAIT  # one round per slot
    clock.advance(HOUR)  # 13:00:07
    assert schedule.check(clock(), newer).action == Action.SEND


def test_no_new_fix_is_said_once_and_the_round_goes_when_one_comes() -> None:
    clock = Clock(at(12, 0, 1))
    schedule = PositionSchedule(
        period_s=HOUR, started_at=at(9, 0), last_sent_at=at(11, 0, 3), last_fix_at=at(11, 0)
    )
    schedule.hold_s = 0
    first = schedule.check(clock(), at(11, 0))
    assert (first.action, first.say) == (Action.NO_NEW_FIX, True)
    clock.advance(HOUR * 3)  # hours of silence: still said only once
    again = schedule.check(clock(), at(11, 0))
    assert (again.action, again.say) == (Action.NO_NEW_FIX, False)
    assert schedule.check(clock(), None).say is False
    assert schedule.check(clock(), at(14, 59)).action == Action.SEND
    schedule.sent(clock(), at(14, 59))
    clock.advance(HOUR)
    assert schedule.check(clock(), at(14, 59)).say is True  # a new stretch without fixes


def test_a_restart_in_the_same_slot_sends_nothing_until_the_next() -> None:
    schedule = PositionSchedule(
        period_s=HOUR, started_at=at(12, 30), last_sent_at=at(12, 0, 2), last_fix_at=at(11, 59)
    )
    assert schedule.check(at(12, 31), at(12, 30)).action == Action.WAIT
    assert schedule.check(at(13, 0), at(12, 30)).action == Action.SEND


def test_a_restart_after_missed_slots_sends_one_round_after_the_hold() -> None:
    schedule = PositionSchedule(
        period_s=600, started_at=at(15, 0, 30), last_sent_at=at(12, 0, 2), last_fix_at=at(11, 59)
    )
    assert schedule.due_at() == at(15, 1, 30)  # STARTUP_HOLD_S after the start, not at once
    assert schedule.check(at(15, 1), at(15, 0, 40)).action == Action.WAIT
    assert schedule.check(at(15, 1, 30), at(15, 0, 40)).action == Action.SEND
    schedule.sent(at(15, 1, 30), at(15, 0, 40))
    assert schedule.due_at() == at(15, 10)  # back on the slots


def test_a_last_round_stamped_in_the_future_is_not_believed() -> None:
    schedule = PositionSchedule(
        period_s=HOUR, started_at=START, last_sent_at=START.replace(year=2030)
    )
    assert schedule.last_sent_at is None and schedule.due_at() == at(12, 0)


@given(
    period=st.sampled_from([60.0, 600.0, 3600.0, 86400.0]),
    steps=st.lists(
        st.tuples(st.floats(0, 7200), st.booleans()),  # (seconds passing, a new fix came)
        max_size=80,
    ),
    restarts=st.sets(st.integers(0, 79), max_size=5),
)
def test_never_two_rounds_in_a_slot_nor_a_fix_twice(
    period: float, steps: list[tuple[float, bool]], restarts: set[int]
) -> None:
    clock = Clock(START)
    fix = START - dt.timedelta(minutes=5)
    schedule = PositionSchedule(period_s=period, started_at=clock())
    rounds: list[tuple[dt.datetime, dt.datetime]] = []
    for index, (seconds, new_fix) in enumerate(steps):
        clock.advance(seconds)
        if new_fix:
            fix = clock()
        if index in restarts:  # the state a restart reads back from the SMS log
            last = rounds[-1] if rounds else (None, None)
            schedule = PositionSchedule(
                period_s=period, started_at=clock(), last_sent_at=last[0], last_fix_at=last[1]
            )
        if schedule.check(clock(), fix).action == Action.SEND:
            schedule.sent(clock(), fix)
            rounds.append((clock(), fix))
    slots = [slot_start(sent, period) for sent, _ in rounds]
    assert len(slots) == len(set(slots))
    fixes = [f for _, f in rounds]
    assert fixes == sorted(set(fixes))
    if rounds:
        assert rounds[0][0] >= slot_start(START, period) + dt.timedelta(seconds=period)
