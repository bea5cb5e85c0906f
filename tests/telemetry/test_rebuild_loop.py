"""`manage.py rebuild_track_overview --loop` / `--pending`: the background rebuild of the minutes
ingest marked out of date, which map reads no longer do (issue 17 item 5)."""

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
from django.core.management import CommandError, call_command
from django.db import OperationalError

from telemetry.management.commands import rebuild_track_overview as command_module
from telemetry.models import TrackBucket, TrackDirty
from telemetry.services import fix_ingest, track_overview_rebuild, track_overview_refresh
from tests.support import BASE, iso
from vessels.models import Vessel

# The command calls close_old_connections(), which closes a connection left inside the
# test-case transaction; real transactions (as in production) keep it usable.
pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture(autouse=True)
def _keep_signal_handlers() -> Iterator[None]:
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGTERM, signal.SIGINT)}
    yield
    for sig, handler in saved.items():
        signal.signal(sig, handler)


def ingest(vessel: Vessel, *offsets_s: float) -> None:
    fix_ingest(vessel=vessel, records=[
        {"time": iso(BASE + dt.timedelta(seconds=s)), "lat": -32 + s / 1e6, "lon": 115.7}
        for s in offsets_s
    ])  # fmt: skip


def buckets(vessel: Vessel) -> list[tuple[Any, ...]]:
    return sorted(TrackBucket.objects.filter(vessel=vessel).values_list("width", "start", "count"))


def command() -> command_module.Command:
    return command_module.Command(stdout=io.StringIO(), stderr=io.StringIO())


def test_a_pass_rebuilds_every_vessels_marked_minutes(vessel_a: Vessel, vessel_b: Vessel) -> None:
    ingest(vessel_a, 0, 30, 3700)
    track_overview_refresh(vessel_id=vessel_a.pk)
    ingest(vessel_a, 45, 7300)  # into built buckets, and a new hour
    ingest(vessel_b, 10)
    call_command("rebuild_track_overview", "--pending")
    assert not TrackDirty.objects.exists()
    incremental = buckets(vessel_a), buckets(vessel_b)
    track_overview_rebuild(vessel=vessel_a)
    track_overview_rebuild(vessel=vessel_b)
    assert (buckets(vessel_a), buckets(vessel_b)) == incremental
    assert (60, int(BASE.timestamp()), 3) in incremental[0]


def test_a_backlog_is_rebuilt_a_day_per_transaction_and_spread_over_passes(
    vessel_a: Vessel, monkeypatch: pytest.MonkeyPatch
) -> None:
    day = 86400
    ingest(vessel_a, *(-d * day + 60 * m for d in range(4) for m in range(3)))  # not future
    claims: list[int] = []
    real = command_module.track_overview_refresh

    def refresh(**kwargs: Any) -> int:
        claims.append(done := real(**kwargs))
        return done

    monkeypatch.setattr(command_module, "track_overview_refresh", refresh)
    monkeypatch.setattr(command_module, "WINDOWS_PER_PASS", 3)
    cmd = command()
    assert cmd.do_one_pass() == 9  # three days' minutes, one day per claim
    assert claims == [3, 3, 3]
    assert TrackDirty.objects.count() == 3  # the fourth day waits for the next pass
    assert cmd.do_one_pass() == 3
    assert not TrackDirty.objects.exists()


def test_a_failing_vessel_backs_off_and_the_others_carry_on(
    vessel_a: Vessel,
    vessel_b: Vessel,
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    ingest(vessel_a, 0)
    ingest(vessel_b, 0)
    calls: list[int] = []
    real = command_module.track_overview_refresh

    def refresh(*, vessel_id: int, **kwargs: Any) -> int:
        calls.append(vessel_id)
        if vessel_id == vessel_a.pk:
            raise OperationalError("canceling statement due to statement timeout")
        return real(vessel_id=vessel_id, **kwargs)

    monkeypatch.setattr(command_module, "track_overview_refresh", refresh)
    cmd = command()
    now = [1000.0]
    cmd.clock = lambda: now[0]
    with caplog.at_level(logging.WARNING):
        cmd.do_one_pass()
        assert calls == [vessel_a.pk, vessel_b.pk, vessel_b.pk]  # B rebuilt despite A
        assert not TrackDirty.objects.filter(vessel=vessel_b).exists()
        tracebacks = [r for r in caplog.records if r.exc_info]
        assert len(tracebacks) == 1
        # Passes within the back-off leave A alone: no call, no log line.
        for _ in range(5):
            now[0] += 1
            cmd.do_one_pass()
        assert calls.count(vessel_a.pk) == 1
        assert len([r for r in caplog.records if r.exc_info]) == 1
        now[0] = 1000 + command_module.RETRY_FIRST_S
        cmd.do_one_pass()  # retried, failed again: the wait doubles
        assert calls.count(vessel_a.pk) == 2
        now[0] += command_module.RETRY_FIRST_S
        cmd.do_one_pass()
        assert calls.count(vessel_a.pk) == 2
    monkeypatch.setattr(command_module, "track_overview_refresh", real)
    now[0] += command_module.RETRY_FIRST_S
    cmd.do_one_pass()  # recovered: rebuilt, and its failures forgotten
    assert not TrackDirty.objects.exists()
    assert cmd.failures == {}
    assert command_module.retry_delay(30) == command_module.RETRY_MAX_S


def test_the_loop_rebuilds_and_stops_on_a_signal_during_its_wait(vessel_a: Vessel) -> None:
    ingest(vessel_a, 0, 20)
    cmd = command()
    waits: list[float] = []

    def sleep(seconds: float) -> None:
        waits.append(seconds)
        if len(waits) == 2:
            os.kill(os.getpid(), signal.SIGTERM)

    cmd.sleep = sleep
    with mock.patch.object(
        command_module,
        "track_overview_dirty_vessels",
        wraps=command_module.track_overview_dirty_vessels,
    ) as listed:
        call_command(cmd, "--loop", "--interval", "30")
    assert len(waits) == 2 and listed.call_count == 1  # stopped at once, one pass only
    assert not TrackDirty.objects.exists()
    assert TrackBucket.objects.filter(vessel=vessel_a, width=60).get().count == 2


def test_loop_and_pending_take_no_slugs(vessel_a: Vessel) -> None:
    with pytest.raises(CommandError, match="no vessel slugs"):
        call_command("rebuild_track_overview", "spab", "--pending")
