"""Personas for the alerts API: an operator with the alert and fence rights (carol), the
fleet operator without them (alice, tests/conftest.py), a stranger (bob: no rights)."""

from __future__ import annotations

import pytest
from rest_framework.test import APIClient

from tests.conftest import OPERATOR_PERMS, make_user

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
