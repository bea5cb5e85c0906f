"""The glider's position by SMS (issue 20 §5): on a schedule, one SMS to each authorised number
that receives positions, through the modem loop like any reply.

References: :mod:`sms.bridge.position_schedule` (when), :mod:`sms.position_text` (what: one
GSM-7 SMS of at most 160 septets), :mod:`sms.services.positions` (the SMS queued in the log).

:meth:`PositionReporter.do_one` is a step of the bridge's housekeeping (about once a second).
It reads the database only when a round is due: the schedule's place once at the first call
(the vessel's newest position SMS in the log), then the last fix while a round waits for one.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import logging
from collections.abc import Callable

from django.utils import timezone

from sms.services import position_last_round, position_report, position_state, sms_position_queue
from vessels.models import Vessel

from .position_schedule import STARTUP_HOLD_S, Action, PositionSchedule, check_period

log = logging.getLogger(__name__)


class PositionReporter:
    """Queue the position SMS of ``vessel`` every ``period_s`` (0: never)."""

    def __init__(
        self,
        *,
        vessel: Vessel,
        period_s: float,
        nudge: Callable[[], None] = lambda: None,
        refresh: Callable[[], object] | None = None,
        cc_silent_s: Callable[[], float | None] = lambda: None,
        now: Callable[[], dt.datetime] = timezone.now,
        hold_s: float = STARTUP_HOLD_S,
    ) -> None:
        check_period(period_s)
        self.vessel = vessel
        self.period_s = period_s
        self.nudge = nudge
        self.refresh = refresh
        self.cc_silent_s = cc_silent_s
        self.now = now
        self.hold_s = hold_s
        self.schedule: PositionSchedule | None = None
        self.rounds = 0
        self.queued = 0
        self._said_nobody = False

    def do_one(self) -> bool:
        """Queue a round if one is due and there is a fix to send; True if SMS were queued."""
        if not self.period_s:
            return False
        now = self.now()
        schedule = self.schedule or self._start(now)
        if not schedule.is_due(now):
            return False
        if self.refresh is not None:
            self.refresh()  # the fixes still held in memory written first
        report = position_report(vessel=self.vessel)
        decision = schedule.check(now, report.time if report else None)
        if decision.action is Action.NO_NEW_FIX:
            if decision.say:
                since = (
                    f"the one of {schedule.last_fix_at:%Y-%m-%d %H:%M:%S} UTC"
                    if (schedule.last_fix_at)
                    else "none at all"
                )
                log.info("position SMS due, but no fix newer than %s: not sent until one comes",
                         since)  # fmt: skip
            return False
        if decision.action is not Action.SEND or report is None:
            return False
        state = position_state(vessel=self.vessel, cc_silent_s=self.cc_silent_s())
        report = dataclasses.replace(report, state=state)
        result = sms_position_queue(vessel=self.vessel, report=report, now=now)
        schedule.sent(now, report.time)
        self.rounds += 1
        self.queued += len(result.queued)
        if result.queued:
            self._said_nobody = False
            numbers = ", ".join(message.number for message in result.queued)
            log.info("position SMS queued for %s: %s", numbers, result.text)
            self.nudge()
        elif not result.already and not self._said_nobody:
            self._said_nobody = True
            log.info("position SMS due, but no authorised number receives positions")
        return bool(result.queued)

    def _start(self, now: dt.datetime) -> PositionSchedule:
        last = position_last_round(vessel=self.vessel)
        self.schedule = PositionSchedule(
            period_s=self.period_s,
            started_at=now,
            last_sent_at=last.sent_at if last else None,
            last_fix_at=last.fix_at if last else None,
            hold_s=self.hold_s,
        )
        due = self.schedule.due_at()
        log.info("position SMS every %g s; the next round from %s", self.period_s,
                 f"{due:%Y-%m-%d %H:%M:%S} UTC" if due else "never")  # fmt: skip
        return self.schedule
