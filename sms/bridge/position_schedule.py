"""When the bridge texts the glider's position (issue 20 §5): a schedule on the UTC clock.

Pure: no Django, no I/O; the caller gives the times (a fake clock in tests).

* The rounds fall in slots of ``period_s`` counted from the Unix epoch (a period of 3600 s:
  one round an hour, the first fix after the hour), so the schedule does not depend on when
  the bridge started, and a restart finds its place again from the last round's time, which
  the SMS log keeps.
* At most one round per slot. A round goes out once its slot has come and there is a fix newer
  than the one the last round sent; until one comes, nothing is sent (the caller says so once,
  ``Decision.say``), and the round goes out as soon as one does.
* No burst at start-up: a bridge that never sent a round waits for the next slot; one that did
  sends at most one round for all the slots it missed while stopped, and not before
  ``hold_s`` after starting, so that the C&C's first fix of the new run can come in first.
* A last round stamped more than one period ahead of the clock (the Pi's clock was wrong then,
  or is now) is not believed: the schedule goes on as after a first start.
"""

from __future__ import annotations

import datetime as dt
import enum
import math
from dataclasses import dataclass

EPOCH = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
# The shortest period a glider may be given: one SMS per number per minute at most (a typo of
# "6" for "600" must not cost a hundred SMS an hour).
MIN_PERIOD_S = 60.0
# After a start, the first round waits this long for the C&C's first fix (its poll: 20 s).
STARTUP_HOLD_S = 60.0


class Action(enum.Enum):
    OFF = "off"  # no schedule (period 0)
    WAIT = "wait"  # the slot has not come
    NO_NEW_FIX = "no new fix"  # due, but nothing newer than the last round's fix
    SEND = "send"


@dataclass(frozen=True, slots=True)
class Decision:
    action: Action
    due_at: dt.datetime | None = None  # when the next round may go
    say: bool = False  # NO_NEW_FIX for the first time since the last round: log it


def check_period(period_s: float) -> None:
    """ValueError unless the period is 0 (off) or at least MIN_PERIOD_S."""
    if not math.isfinite(period_s) or (period_s != 0 and period_s < MIN_PERIOD_S):
        raise ValueError(
            f"position_sms_period_s must be 0 (off) or at least {MIN_PERIOD_S:g}, not {period_s}"
        )


def slot_start(when: dt.datetime, period_s: float) -> dt.datetime:
    """The start of the slot ``when`` falls in."""
    elapsed = (when - EPOCH).total_seconds()
    return EPOCH + dt.timedelta(seconds=math.floor(elapsed / period_s) * period_s)


class PositionSchedule:
    """The schedule's state: the last round (time, fix) and whether 'no new fix' was said."""

    def __init__(
        self,
        *,
        period_s: float,
        started_at: dt.datetime,
        last_sent_at: dt.datetime | None = None,
        last_fix_at: dt.datetime | None = None,
        hold_s: float = STARTUP_HOLD_S,
    ) -> None:
        check_period(period_s)
        self.period_s = period_s
        self.started_at = started_at
        self.hold_s = hold_s
        if last_sent_at is not None and period_s and last_sent_at > started_at + self._period:
            last_sent_at = None  # stamped by a clock that was wrong: not believed
        self.last_sent_at = last_sent_at
        self.last_fix_at = last_fix_at
        self._said = False

    @property
    def _period(self) -> dt.timedelta:
        return dt.timedelta(seconds=self.period_s)

    def due_at(self) -> dt.datetime | None:
        """When the next round may go (None: off)."""
        if not self.period_s:
            return None
        if self.last_sent_at is None:
            first = slot_start(self.started_at, self.period_s) + self._period
        else:
            first = slot_start(self.last_sent_at, self.period_s) + self._period
        return max(first, self.started_at + dt.timedelta(seconds=self.hold_s))

    def is_due(self, now: dt.datetime) -> bool:
        """The time has come (whether or not there is a fix to send)."""
        due = self.due_at()
        return due is not None and now >= due

    def check(self, now: dt.datetime, latest_fix_at: dt.datetime | None) -> Decision:
        """What to do now, given the time of the newest fix known (None: none at all)."""
        due = self.due_at()
        if due is None:
            return Decision(Action.OFF)
        if now < due:
            return Decision(Action.WAIT, due)
        if latest_fix_at is None or (
            self.last_fix_at is not None and latest_fix_at <= self.last_fix_at
        ):
            say = not self._said
            self._said = True
            return Decision(Action.NO_NEW_FIX, due, say=say)
        return Decision(Action.SEND, due)

    def sent(self, now: dt.datetime, fix_at: dt.datetime) -> None:
        """A round went out (or had nobody to go to) at ``now`` with the fix of ``fix_at``."""
        self.last_sent_at = now
        self.last_fix_at = fix_at
        self._said = False
