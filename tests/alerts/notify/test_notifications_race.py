"""Two senders racing (two ``run_alerts`` side by side): real transactions on a real database,
in two threads; each notification goes out once.

The race is made to happen, not hoped for: each sender, watched statement by statement, stops
after reading the due notifications until the other has read them too, so both hold the same
candidates before either claims; then both claim. Exactly one claim UPDATE takes the rows.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Callable
from typing import Any

import pytest
from django.db import connection

from alerts.models import Notification
from alerts.services.notifications import notifications_queue, notifications_send_due
from tests.alerts.notify.conftest import (
    BASE,
    SECRET,
    Receiver,
    Smtp,
    make_alert,
    make_channel,
    make_rule,
    make_vessel,
)

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]
WAIT_S = 20  # only ever reached when something is broken
BOATS = 12
# The sender's read of the due notifications (ids, state, attempts; the later read of the
# claimed rows joins their alerts and has no LIMIT).
CANDIDATES = re.compile(r'SELECT [^*]*? FROM "alerts_notification" WHERE (?!.*JOIN).* LIMIT')


class Watch:
    """An execute wrapper: after the candidate read, wait for the other sender's; note how many
    rows this sender's claim UPDATE took."""

    def __init__(self, both_read: threading.Barrier) -> None:
        self.both_read = both_read
        self.claimed: list[int] = []
        self.reads = 0

    def __call__(self, execute: Callable, sql: str, params: Any, many: bool, context: Any) -> Any:
        result = execute(sql, params, many, context)
        if CANDIDATES.match(sql):
            self.reads += 1
            self.both_read.wait(WAIT_S)
        elif sql.startswith('UPDATE "alerts_notification"') and "claimed_by" in sql:
            if "attempts" in sql:  # the claim, not a settlement
                self.claimed.append(context["cursor"].rowcount)
        return result


def race() -> tuple[list[int], list[int]]:
    """Both senders at once; (rows each claimed, notifications each delivered)."""
    both_read = threading.Barrier(2)
    watches = [Watch(both_read), Watch(both_read)]
    delivered = [0, 0]
    errors: list[BaseException] = []

    def sender(i: int) -> None:
        try:
            with connection.execute_wrapper(watches[i]):
                delivered[i] = notifications_send_due(now=BASE, worker=f"w{i}")
        except BaseException as exc:  # noqa: BLE001 - reported by the main thread
            errors.append(exc)
        finally:
            connection.close()

    threads = [threading.Thread(target=sender, args=(i,)) for i in range(2)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(WAIT_S * 2)
    assert not errors, errors
    assert [w.reads for w in watches] == [1, 1]  # each waited for the other's read
    return sorted(n for w in watches for n in w.claimed), delivered


def test_two_senders_racing_post_each_webhook_once(receiver: Receiver) -> None:
    hook = make_channel("webhook", receiver.url, secret=SECRET)
    rule = make_rule("Overdue", hook)
    for i in range(BOATS):
        notifications_queue(alert=make_alert(rule, make_vessel(f"b{i}")), event="alert.opened",
                            now=BASE)  # fmt: skip
    claimed, delivered = race()
    assert claimed == [0, BOATS]  # both read the same rows; one claim took them all
    assert sorted(delivered) == [0, BOATS]
    ids = sorted(r.json()["alert"]["id"] for r in receiver.received)
    assert ids == sorted(Notification.objects.values_list("alert_id", flat=True))
    assert len(set(ids)) == BOATS
    assert set(Notification.objects.values_list("state", "attempts")) == {("sent", 1)}


def test_two_senders_racing_send_a_flood_as_one_summary(smtp_server: Smtp) -> None:
    rule = make_rule("Overdue", make_channel("email", "ops@shore.test"))
    for i in range(BOATS):
        notifications_queue(alert=make_alert(rule, make_vessel(f"b{i}")), event="alert.opened",
                            now=BASE)  # fmt: skip
    claimed, delivered = race()
    assert claimed == [0, BOATS]
    assert sorted(delivered) == [0, BOATS]
    [mail] = smtp_server.messages
    assert mail["Subject"].startswith(f"[Shoreside] ALERT x{BOATS}:")
    assert Notification.objects.filter(summarised_in__isnull=False).count() == BOATS - 1
