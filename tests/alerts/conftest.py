"""Alerts fixtures: a rule maker, a channel, an evaluator and a clock at a whole hour."""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import time_machine

from alerts.evaluator import Evaluator
from alerts.models import AlertRule, NotificationChannel
from telemetry.services import fix_ingest
from vessels.models import Vessel

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
