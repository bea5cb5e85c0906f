"""The three services the operator API and the admin call that other parts of issue 19 own,
imported from their owners when those are present:

- ``alert_acknowledge(alert=, by=, now=)`` from alerts.services.alerts (the evaluator's);
- ``notification_channel_create(*, name, kind, target, secret=None, by)`` from
  alerts.services.notifications (the notifiers');
- ``fence_send(*, fence, vessel, created_by, source)`` from commands.services (the fence
  command's).

Until they are merged, each falls back to the minimal version below with the same signature
and the same writes, so the API and admin work on their own branch. The fallbacks are
replaced by the owners' functions at merge: delete the ``except ImportError`` branches.
"""

from __future__ import annotations

import datetime as dt
import secrets
from typing import Any

from django.db import transaction
from django.utils import timezone

from alerts.models import Alert, AlertState, ChannelKind, NotificationChannel
from audit.services import audit_record
from commands.models import Command
from vessels.models import Fence, Vessel

try:
    from alerts.services.alerts import alert_acknowledge
except ImportError:  # replaced by alerts.services.alerts.alert_acknowledge at merge

    @transaction.atomic
    def alert_acknowledge(*, alert: Alert, by: str, now: dt.datetime | None = None) -> Alert:
        """Acknowledge an open alert (who, when): a conditional UPDATE, so two operators
        acknowledging at once record one of them. An alert acknowledged or resolved already
        is returned as it is."""
        now = now or timezone.now()
        claimed = Alert.objects.filter(pk=alert.pk, state=AlertState.OPEN).update(
            state=AlertState.ACKNOWLEDGED, acknowledged_at=now, acknowledged_by=by
        )
        alert.refresh_from_db()
        if claimed:
            audit_record(
                action="alert.acknowledged", actor=by, subject_type="alert",
                subject_id=alert.pk, subject=str(alert), vessel=alert.vessel.slug, now=now,
            )  # fmt: skip
        return alert


try:
    from alerts.services.notifications import notification_channel_create
except ImportError:  # replaced by alerts.services.notifications.notification_channel_create
    # A webhook's HMAC-SHA256 key: 32 random bytes, as hex.
    WEBHOOK_SECRET_BYTES = 32

    @transaction.atomic
    def notification_channel_create(
        *, name: str, kind: str, target: str, secret: str | None = None, by: str
    ) -> tuple[NotificationChannel, str]:
        """A new channel; a webhook's secret (given, or generated) is returned here, once."""
        if kind == ChannelKind.WEBHOOK and not secret:
            secret = secrets.token_hex(WEBHOOK_SECRET_BYTES)
        channel = NotificationChannel(name=name, kind=kind, target=target, secret=secret or "")
        channel.full_clean()
        channel.save()
        audit_record(
            action="channel.created", actor=by, subject_type="notification_channel",
            subject_id=channel.pk, subject=str(channel), detail={"target": target},
        )  # fmt: skip
        return channel, channel.secret


try:
    from commands.services import fence_send  # type: ignore[attr-defined]
except ImportError:  # replaced by commands.services.fence_send at merge

    def fence_send(*, fence: Fence, vessel: Vessel, created_by: str, source: str) -> Command:
        """Queue ``fence`` as a ``fence`` command for ``vessel``: the catalog judges it (a
        build without the fence kind refuses it by name)."""
        from commands.services import command_enqueue

        params: dict[str, Any] = {
            "fence_id": fence.pk,
            "inclusion": fence.inclusion,
            "geometry": fence.geometry,
            "radius_m": fence.radius_m,
        }
        return command_enqueue(
            vessel=vessel, kind="fence", params=params, source=source, created_by=created_by
        )


__all__ = ["alert_acknowledge", "fence_send", "notification_channel_create"]
