"""`manage.py expire_commands`: the cron/loop face of command_expire_due."""

from __future__ import annotations

import datetime as dt
import io
import signal
from collections.abc import Iterator

import pytest
from django.core.management import call_command
from django.utils import timezone

from commands.lifecycle import Status
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
