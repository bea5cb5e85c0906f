"""Random runs of the C&C talking to the database-backed command source (hypothesis stateful):
polls, requests, retries, answers, timeouts, cancels and bridge restarts in any order.

The properties (issue 11 §2; §8.6, §10 of docs/level2.md):
* no command is handed over twice: one queued → sent event each, and a command handed over
  again is only ever the answer to a retry of the same request (same tid);
* a C&C answer changes at most the command handed over last, and only while that one awaits
  its answer (not after its timeout): never the next one;
* a handed-over command never goes back to queued.
"""

from __future__ import annotations

import datetime as dt
import itertools

import pytest
from django.db.models import Count
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule, run_state_machine_as_test

from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from commands.services import command_cancel, command_enqueue
from sms.bridge.commands import DatabaseCommandSource
from sms.bridge.machine import BridgeMachine
from sms.level2.codec import Frame
from sms.level2.payload import CommandHandedOver, Enumerated, ResultWithoutCommand
from vessels.services import vessel_create

from .conftest import Clock, queued, result, status

pytestmark = [pytest.mark.slow, pytest.mark.django_db]

SLUGS = (f"glider-run-{i}" for i in itertools.count())
PARAMS = {
    "light": {"state": "ON"},
    "waypoint": {"index": 3, "lat": -32.0, "lon": 115.5},
    "ir": {"state": "OFF"},  # provisional: refused by the table
}


class BridgeRun(RuleBasedStateMachine):
    def __init__(self) -> None:
        super().__init__()
        self.clock = Clock(dt.datetime.now(dt.UTC))
        self.vessel = vessel_create(slug=next(SLUGS), name="Glider", kind="wave_glider")
        self.tids = itertools.count(0x100)
        self.last_request: Frame | None = None
        self.handed: dict[str, int] = {}  # uid → the tid of the request that took it
        self.outstanding: str | None = None  # handed over, answer not yet come or timed out
        self.start()

    def start(self) -> None:
        self.source = DatabaseCommandSource(
            vessel=self.vessel, result_timeout_s=60, quarantine_s=30, clock=self.clock
        )
        self.machine = BridgeMachine(source=self.source)

    def feed(self, frame: Frame) -> None:
        self.machine.handle(frame)
        for note in self.machine.notifications():
            if isinstance(note, CommandHandedOver):
                assert self.handed.setdefault(note.ident, note.tid) == note.tid, "handed twice"
                if note.ident != self.outstanding:
                    self.outstanding = note.ident
            elif isinstance(note, ResultWithoutCommand):
                self.source.result_without_command(note.code)
            elif isinstance(note, Enumerated):
                self.source.forget_request_ids()

    def answers(self) -> dict[str, tuple[str, str]]:
        return {
            str(c.uid): (c.status, c.result_detail)
            for c in Command.objects.filter(vessel=self.vessel)
        }

    @rule(kind=st.sampled_from(sorted(PARAMS)))
    def enqueue(self, kind: str) -> None:
        command_enqueue(vessel=self.vessel, kind=kind, params=PARAMS[kind])

    @rule()
    def poll(self) -> None:
        self.feed(status(next(self.tids)))

    @rule()
    def request_queued(self) -> None:
        self.last_request = queued(next(self.tids))
        self.feed(self.last_request)

    @rule()
    def retry_last_request(self) -> None:
        if self.last_request is not None:
            self.feed(self.last_request)

    @rule(code=st.integers(0, 4))
    def answer(self, code: int) -> None:
        before = self.answers()
        self.feed(result(code, next(self.tids)))
        changed = {uid for uid, now in self.answers().items() if before.get(uid) != now}
        assert changed <= {self.outstanding}, "an answer went to a command not awaiting one"
        if self.outstanding is not None:
            self.outstanding = None

    @rule(seconds=st.integers(0, 100))
    def time_passes(self, seconds: int) -> None:
        self.clock.advance(seconds)
        if self.source.expire_overdue():
            self.outstanding = None

    @rule()
    def restart(self) -> None:
        self.start()

    @rule(data=st.data())
    def operator_cancels(self, data: st.DataObject) -> None:
        open_commands = list(
            Command.objects.filter(vessel=self.vessel, status__in=[Status.QUEUED, Status.SENT])
        )
        if open_commands:
            command_cancel(command=data.draw(st.sampled_from(open_commands)), actor="op")

    @invariant()
    def handed_over_once_and_never_queued_again(self) -> None:
        twice = (
            CommandEvent.objects.filter(
                command__vessel=self.vessel, from_status="queued", to_status="sent"
            )
            .values("command")
            .annotate(n=Count("id"))
            .filter(n__gt=1)
        )
        assert not twice.exists()
        statuses = self.answers()
        assert all(statuses[uid][0] != Status.QUEUED for uid in self.handed)


def test_random_runs_keep_every_command_handed_over_once_and_answers_in_place() -> None:
    run_state_machine_as_test(
        BridgeRun,
        settings=settings(
            max_examples=30,
            stateful_step_count=30,
            deadline=None,
            suppress_health_check=[HealthCheck.too_slow],
        ),
    )
