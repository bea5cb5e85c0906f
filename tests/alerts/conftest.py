"""Alerts fixtures: personas for the API (carol: an operator with the alert and fence rights;
alice, tests/conftest.py: the fleet operator without them; bob: a stranger), a rule maker, a
channel, an evaluator and a clock at a whole hour."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import time_machine
from rest_framework.test import APIClient

from alerts.evaluator import Evaluator
from alerts.models import AlertRule, NotificationChannel
from telemetry.services import fix_ingest
from tests.conftest import OPERATOR_PERMS, make_user
from vessels.models import Vessel

ALERT_PERMS = [
    *OPERATOR_PERMS,
    *(f"alerts.{verb}_{model}" for verb in ("view", "add", "change", "delete")
      for model in ("alertrule", "alert", "notificationchannel")),
    *(f"vessels.{verb}_fence" for verb in ("view", "add", "change", "delete")),
]  # fmt: skip


@pytest.fixture
def watch_user(db):
    """Carol: watches the fleet (alert rules, alerts, channels, fences) and commands it."""
    return make_user("carol", ALERT_PERMS)


@pytest.fixture
def watcher(watch_user) -> APIClient:
    client = APIClient()
    client.force_authenticate(watch_user)
    return client


T0 = dt.datetime(2026, 11, 23, 10, 0, tzinfo=dt.UTC)


@pytest.fixture
def clock() -> Iterator[Any]:
    with time_machine.travel(T0, tick=False) as traveller:
        yield traveller


@pytest.fixture
def channel(db: None) -> NotificationChannel:
    return NotificationChannel.objects.create(
        name="duty phone", kind="webhook", target="http://127.0.0.1:9/hook"
    )


@pytest.fixture
def make_rule(channel: NotificationChannel) -> Callable[..., AlertRule]:
    def make(**fields: Any) -> AlertRule:
        fields.setdefault("name", f"{fields['kind']} rule")
        rule = AlertRule(**fields)
        rule.full_clean()
        rule.save()
        rule.channels.add(channel)
        return rule

    return make


@pytest.fixture
def evaluator(clock: Any) -> Evaluator:
    return Evaluator()


def report(vessel: Vessel, when: dt.datetime | None = None, **fields: Any) -> None:
    """The vessel posts one fix now (or recorded at ``when``) through the ingest service."""
    from django.utils import timezone

    when = when or timezone.now()
    record = {"time": when.isoformat(), "lat": -32.02, "lon": 115.70, **fields}
    result = fix_ingest(vessel=vessel, records=[record])
    assert result.accepted == 1, result
