"""bench.notify runs end to end on a few notifications (its figures are not checked)."""

from __future__ import annotations

import pytest

from alerts.models import Notification
from bench import notify


@pytest.mark.django_db
def test_the_notification_bench_runs(capsys: pytest.CaptureFixture[str]) -> None:
    assert notify.main(["--count", "8", "--limit", "5"]) == 0
    out = capsys.readouterr().out
    assert "webhooks    8 sent in 2 passes" in out
    # 5 due at once are a flood (more than ALERTS_NOTIFY_FLOOD, 3): one text; the 3 left, one each
    assert "flood (SMS) 8 summarised in 4 texts, 2 passes" in out
    assert set(Notification.objects.values_list("state", flat=True)) == {"sent"}
