"""Notifications owed for alert events.

A minimal version kept by the evaluator's branch until the notifications branch (transports,
sending, retries, flood summary) replaces this module at merge: it only queues rows.
"""

from __future__ import annotations

import datetime as dt

from django.utils import timezone

from alerts.models import Alert, Notification


def notifications_queue(*, alert: Alert, event: str, now: dt.datetime | None = None) -> int:
    """Queue one Notification per active channel of the alert's rule, due at once; how many.
    Called inside the transaction that changed the alert, so an event and its messages commit
    (or roll back) together."""
    now = now or timezone.now()
    # .all(): the evaluator prefetches each rule's channels once per pass.
    channels = [c for c in alert.rule.channels.all() if c.active]
    rows = [
        Notification(alert=alert, channel=c, event=event, created_at=now, due_at=now)
        for c in channels
    ]
    Notification.objects.bulk_create(rows)
    return len(rows)
