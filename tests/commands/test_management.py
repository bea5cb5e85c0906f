"""`manage.py expire_commands`: the cron/loop face of command_expire_due."""

from __future__ import annotations

import datetime as dt
import io
import logging
import os
import signal
from collections.abc import Iterator
from typing import Any
from unittest import mock

import pytest
from django.core.management import call_command
from django.db import OperationalError
from django.utils import timezone

from commands.lifecycle import Status
from commands.management.commands import expire_commands
from commands.services import command_enqueue
from vessels.models import Vessel

# The command calls close_old_connections(), which closes a connection left inside the
# test-case transaction; real transactions (as in production) keep it usable.
pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture(autouse=True)
def _keep_signal_handlers() -> Iterator[None]:
    # The command installs SIGTERM/SIGINT handlers for its loop; Ctrl-C must still stop pytest.
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGINT)}
    yield
    for sig, handler in saved.items():
        signal.signal(sig, handler)


def test_one_pass_expires_only_what_is_due(vessel_a: Vessel, time_machine) -> None:
    soon = command_enqueue(
        vessel=vessel_a, kind="arm", params={}, expires_at=timezone.now() + dt.timedelta(minutes=1)
    )
    later = command_enqueue(
        vessel=vessel_a, kind="disarm", params={}, expires_at=timezone.now() + dt.timedelta(hours=1)
    )
    time_machine.move_to(timezone.now() + dt.timedelta(minutes=2))
    out = io.StringIO()
    call_command("expire_commands", stdout=out)
    assert out.getvalue().strip() == "expired 1 command(s)"
    soon.refresh_from_db()
    later.refresh_from_db()
    assert (soon.status, later.status) == (Status.EXPIRED, Status.QUEUED)
    assert soon.events.last().detail == "not delivered before expires_at"


def test_a_pass_with_nothing_due_says_nothing(vessel_a: Vessel) -> None:
    command_enqueue(vessel=vessel_a, kind="arm", params={})
    out = io.StringIO()
    call_command("expire_commands", stdout=out)
    assert out.getvalue() == ""


# --- the --loop service: never crash-loops, stops on a signal, leaves the handlers as it found them


def _command() -> expire_commands.Command:
    return expire_commands.Command(stdout=io.StringIO(), stderr=io.StringIO())


def _signal_self(signum: int = signal.SIGTERM) -> None:
    os.kill(os.getpid(), signum)  # what systemd (SIGTERM) or Ctrl-C (SIGINT) does


def _ignore_signal(signum: int, frame: Any) -> None:
    pass


def test_a_failing_pass_is_logged_and_the_loop_carries_on(caplog: pytest.LogCaptureFixture) -> None:
    events: list[str] = []
    outcomes: Iterator[Exception | int] = iter(
        [OperationalError("server closed the connection unexpectedly"), 2]
    )

    def one_pass(**kwargs: Any) -> int:
        outcome = next(outcomes)
        if isinstance(outcome, Exception):
            events.append("failed pass")
            raise outcome
        events.append("pass")
        _signal_self()  # the service is stopped during the second pass
        return outcome

    command = _command()
    waits: list[float] = []
    command.sleep = waits.append
    with (
        mock.patch.object(
            expire_commands, "command_expire_due", autospec=True, side_effect=one_pass
        ) as service,
        mock.patch.object(
            expire_commands,
            "close_old_connections",
            autospec=True,
            side_effect=lambda: events.append("close"),
        ),
        caplog.at_level(logging.ERROR),
    ):
        call_command(command, "--loop", "--interval", "5")
    assert service.call_count == 2
    # The failure waited one whole interval (no hammering a sick database), then passed again.
    assert sum(waits) == pytest.approx(5)
    assert command.stdout.getvalue().strip() == "expired 2 command(s)"
    # The connection the failure may have broken is let go before the next pass.
    assert events[events.index("failed pass") + 1] == "close"
    [record] = [r for r in caplog.records if r.name == expire_commands.__name__]
    assert record.levelno == logging.ERROR
    assert "the pass failed" in record.getMessage()
    assert record.exc_info is not None and record.exc_info[0] is OperationalError


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_the_loop_ends_on_a_signal_during_its_wait(
    vessel_a: Vessel, time_machine, signum: int
) -> None:
    due = command_enqueue(
        vessel=vessel_a, kind="arm", params={}, expires_at=timezone.now() + dt.timedelta(minutes=1)
    )
    time_machine.move_to(timezone.now() + dt.timedelta(minutes=2))
    command = _command()
    waits: list[float] = []

    def sleep(seconds: float) -> None:
        waits.append(seconds)
        if len(waits) == 3:
            _signal_self(signum)

    command.sleep = sleep
    call_command(command, "--loop", "--interval", "60")
    assert len(waits) == 3  # it stopped waiting at once, not at the end of the 60 s interval
    assert command.stdout.getvalue().strip() == "expired 1 command(s)"  # one pass only
    due.refresh_from_db()
    assert due.status == Status.EXPIRED


@pytest.mark.parametrize("args", [[], ["--loop"]], ids=["once", "loop"])
def test_the_previous_signal_handlers_are_restored(args: list[str]) -> None:
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, _ignore_signal)
    command = _command()
    command.sleep = lambda _seconds: _signal_self()
    with mock.patch.object(expire_commands, "command_expire_due", autospec=True, return_value=0):
        call_command(command, *args)
    assert signal.getsignal(signal.SIGTERM) is _ignore_signal
    assert signal.getsignal(signal.SIGINT) is _ignore_signal


def test_a_single_failing_pass_fails_the_run_and_restores_the_handlers() -> None:
    # Once (cron) there is no next pass: the error must reach cron's report.
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, _ignore_signal)
    with (
        mock.patch.object(
            expire_commands,
            "command_expire_due",
            autospec=True,
            side_effect=OperationalError("database is locked"),
        ),
        pytest.raises(OperationalError),
    ):
        call_command("expire_commands")
    assert signal.getsignal(signal.SIGTERM) is _ignore_signal
    assert signal.getsignal(signal.SIGINT) is _ignore_signal
