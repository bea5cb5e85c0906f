"""Two evaluators racing over the same database open one episode and queue one notification
per event: real transactions, in two threads (and two run_alerts processes).

The race is made to happen: each thread's connection stops before it reads the active alerts
until the other has reached the same point, so both judge the condition on the same state
before either writes. (Stopping at the INSERT itself would not work on SQLite, where the write
transaction takes the lock at BEGIN IMMEDIATE: the second would wait at BEGIN, not race.)
"""

from __future__ import annotations

import datetime as dt
import os
import subprocess
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from django.db import connection
from django.utils import timezone

from alerts.evaluator import Evaluator
from alerts.models import Alert, AlertRule, Notification
from tests.alerts.conftest import report
from vessels.models import Vessel

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]
ROOT = Path(__file__).resolve().parents[2]
WAIT_S = 10  # only ever reached when something is broken


def in_step(statement: Callable[[str], bool], barrier: threading.Barrier) -> Callable[..., Any]:
    """An execute wrapper that waits at ``barrier`` before the first ``statement``."""
    waited = []

    def wrapper(execute: Callable, sql: str, params: Any, many: bool, context: Any) -> Any:
        if not waited and statement(sql):
            waited.append(sql)
            barrier.wait(WAIT_S)  # broken (a timeout): the test fails on ``waited``
        return execute(sql, params, many, context)

    wrapper.waited = waited  # type: ignore[attr-defined]
    return wrapper


def two_passes(evaluators: list[Evaluator], statement: Callable[[str], bool]) -> list[Any]:
    barrier = threading.Barrier(2)
    results: list[Any] = [None, None]
    wrappers = [in_step(statement, barrier) for _ in evaluators]

    def run(i: int) -> None:
        try:
            with connection.execute_wrapper(wrappers[i]):
                results[i] = evaluators[i].run_pass()
        finally:
            connection.close()

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(3 * WAIT_S)
    assert all(w.waited for w in wrappers), "both reached the deciding statement"
    assert not barrier.broken
    return results


def reads_alerts(sql: str) -> bool:
    return sql.lstrip().upper().startswith("SELECT") and 'FROM "alerts_alert"' in sql


@pytest.fixture
def overdue_boat(vessel_a: Vessel, make_rule: Callable[..., AlertRule]) -> AlertRule:
    rule = make_rule(kind="overdue", threshold=3)
    Vessel.objects.filter(pk=vessel_a.pk).update(
        last_seen_at=timezone.now() - dt.timedelta(minutes=5)
    )
    return rule


def test_two_evaluators_open_one_alert_and_one_notification(overdue_boat: AlertRule) -> None:
    results = two_passes([Evaluator(), Evaluator()], reads_alerts)
    assert sorted(r.opened for r in results) == [0, 1]
    alert = Alert.objects.get(rule=overdue_boat)
    assert list(alert.notifications.values_list("event", flat=True)) == ["alert.opened"]


def test_two_evaluators_resolve_once(overdue_boat: AlertRule, vessel_a: Vessel) -> None:
    Evaluator().run_pass()
    report(vessel_a)  # it speaks again: both evaluators see the condition clear
    results = two_passes([Evaluator(), Evaluator()], reads_alerts)
    assert sorted(r.resolved for r in results) == [0, 1]
    events = Notification.objects.filter(alert__rule=overdue_boat).values_list("event", flat=True)
    assert sorted(events) == ["alert.opened", "alert.resolved"]


def test_two_evaluators_on_one_fix(vessel_a: Vessel, make_rule: Callable[..., AlertRule]) -> None:
    rule = make_rule(kind="battery", threshold=11.5)
    first, second = Evaluator(), Evaluator()
    report(vessel_a, battery_v=11.0)
    two_passes([first, second], reads_alerts)
    assert Alert.objects.filter(rule=rule).count() == 1
    assert Notification.objects.filter(alert__rule=rule).count() == 1


def database_url() -> str:
    s = connection.settings_dict
    if connection.vendor == "sqlite":
        return f"sqlite:///{s['NAME']}"
    return f"postgres://{s['USER']}@{s['HOST'] or '127.0.0.1'}:{s['PORT'] or 5432}/{s['NAME']}"


def test_two_run_alerts_processes_side_by_side(overdue_boat: AlertRule) -> None:
    env = {**os.environ, "DATABASE_URL": database_url(), "PYTHONUNBUFFERED": "1"}
    args = [sys.executable, "manage.py", "run_alerts", "--once", "--skip-checks"]
    procs = [
        subprocess.Popen(args, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        for _ in range(2)
    ]
    outputs = [p.communicate(timeout=60)[0].decode() for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outputs
    assert Alert.objects.filter(rule=overdue_boat).count() == 1
    assert Notification.objects.filter(alert__rule=overdue_boat).count() == 1
