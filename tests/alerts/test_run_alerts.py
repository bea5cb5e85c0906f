"""`manage.py run_alerts`: one pass with --once, the loop in-process, and a real process that
stops cleanly on SIGTERM."""

from __future__ import annotations

import datetime as dt
import os
import signal
import subprocess
import sys
import time
from io import StringIO
from pathlib import Path
from typing import Any

import pytest
from django.core.management import call_command
from django.utils import timezone

from alerts.management.commands.run_alerts import Command as RunAlerts
from alerts.models import Alert, Notification
from tests.alerts.conftest import report
from tests.alerts.test_race import database_url
from vessels.models import Vessel

ROOT = Path(__file__).resolve().parents[2]
# The command calls close_old_connections(), which closes a connection left inside a test's
# transaction: these tests use real transactions (as tests/commands/test_management.py).


def silence(vessel: Vessel, minutes: int = 5) -> None:
    Vessel.objects.filter(pk=vessel.pk).update(
        last_seen_at=timezone.now() - dt.timedelta(minutes=minutes)
    )


@pytest.mark.django_db(transaction=True)
def test_once_runs_one_pass(vessel_a: Vessel, make_rule) -> None:
    rule = make_rule(kind="overdue")
    silence(vessel_a)
    call_command("run_alerts", "--once", stdout=StringIO())
    assert Alert.objects.get(rule=rule).state == "open"
    assert Notification.objects.get(alert__rule=rule).event == "alert.opened"


@pytest.mark.django_db(transaction=True)
def test_once_judges_the_fixes_of_the_last_period(vessel_a: Vessel, make_rule) -> None:
    rule = make_rule(kind="battery", threshold=11.5)
    report(vessel_a, battery_v=11.0)
    call_command("run_alerts", "--once", "--period", "60", stdout=StringIO())
    assert Alert.objects.filter(rule=rule).count() == 1


@pytest.mark.django_db(transaction=True)
def test_a_failing_pass_is_logged_and_the_loop_carries_on(
    vessel_a: Vessel, make_rule, monkeypatch: pytest.MonkeyPatch, caplog: Any
) -> None:
    rule = make_rule(kind="overdue")
    silence(vessel_a)
    command = RunAlerts(stdout=StringIO())
    passes = []
    real = command.do_one_pass

    def flaky() -> bool:
        passes.append(1)
        if len(passes) == 1:
            with monkeypatch.context() as m:
                m.setattr("alerts.evaluator.active_rules", lambda: 1 / 0)
                return real()
        if len(passes) == 2:
            command.stopping = True
        return real()

    from alerts.evaluator import Evaluator

    command.evaluator = Evaluator()
    command.do_one_pass = flaky  # type: ignore[method-assign]
    command.sleep = lambda s: None  # type: ignore[assignment]
    command.run_loop(period=0.01)
    assert len(passes) == 2
    assert "the pass failed" in caplog.text
    assert Alert.objects.filter(rule=rule).count() == 1


@pytest.mark.django_db(transaction=True)
def test_one_pass_opens_the_alert_and_sends_its_notification(
    vessel_a: Vessel, make_rule, mailoutbox
) -> None:
    from alerts.services.notifications import notification_channel_create

    email, _ = notification_channel_create(
        name="duty", kind="email", target="duty@example.org", by="alice"
    )
    rule = make_rule(kind="overdue")
    rule.channels.add(email)
    Vessel.objects.filter(pk=vessel_a.pk).update(
        last_seen_at=timezone.now() - dt.timedelta(hours=1)
    )
    call_command("run_alerts", "--once", stdout=StringIO())
    assert Alert.objects.get(rule=rule).state == "open"
    assert [m.to for m in mailoutbox] == [["duty@example.org"]]
    assert "spab" in mailoutbox[0].subject + mailoutbox[0].body


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_sigterm_stops_a_real_run_alerts_cleanly(
    vessel_a: Vessel, make_rule, tmp_path: Path
) -> None:
    rule = make_rule(kind="overdue")
    env = {**os.environ, "DATABASE_URL": database_url(), "PYTHONUNBUFFERED": "1"}
    log = tmp_path / "run_alerts.log"
    with log.open("w") as out:
        proc = subprocess.Popen(
            [sys.executable, "manage.py", "run_alerts", "--period", "0.5", "--skip-checks"],
            cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT,
        )  # fmt: skip
        try:
            deadline = time.monotonic() + 60
            while "started" not in log.read_text() and time.monotonic() < deadline:
                assert proc.poll() is None, log.read_text()
                time.sleep(0.1)
            silence(vessel_a)  # goes overdue while the loop runs
            while not Alert.objects.filter(rule=rule).exists() and time.monotonic() < deadline:
                time.sleep(0.1)
            assert Alert.objects.filter(rule=rule).exists(), log.read_text()
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=10) == 0
        finally:
            if proc.poll() is None:
                proc.kill()
    text = log.read_text()
    assert "run_alerts: stopped" in text and "Traceback" not in text, text


@pytest.mark.django_db(transaction=True)
def test_pruning_runs_beside_the_passes_when_configured(settings: Any, caplog: Any) -> None:
    settings.ALERTS_PRUNE_EVERY_S = 3600
    command = RunAlerts(stdout=StringIO())
    command.prune_when_due()
    first = command.pruner
    assert first is not None
    first.join(10)
    command.prune_when_due()
    assert command.pruner is first  # not again within the hour
    try:
        import telemetry.retention  # noqa: F401
    except ImportError:
        assert "there is no prune" in caplog.text
