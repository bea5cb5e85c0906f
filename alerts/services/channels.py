"""Changing and deleting notification channels (the admin's). Making one, with its webhook
secret, is notification_channel_create (alerts.services.notifications); a channel's secret
never changes here: a new secret is a new channel, so no receiver is left checking an old one."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from django.db import transaction

from alerts.models import NotificationChannel
from audit.services import audit_changes, audit_record, audit_snapshot

CHANNEL_FIELDS = ("name", "target", "active")


def _audit(channel: NotificationChannel, action: str, *, by: str, **detail: Any) -> None:
    audit_record(
        action=action, actor=by, via="admin", subject_type="notification_channel",
        subject_id=channel.pk, subject=str(channel), detail=detail,
    )  # fmt: skip


@transaction.atomic
def notification_channel_update(
    *, channel: NotificationChannel, fields: Mapping[str, Any], by: str = ""
) -> NotificationChannel:
    """Change a channel's name, target or whether it is used (``active``)."""
    unknown = set(fields) - set(CHANNEL_FIELDS)
    if unknown:
        raise ValueError(f"notification_channel_update cannot change {', '.join(sorted(unknown))}")
    before = audit_snapshot(channel, fields)
    for name, value in fields.items():
        setattr(channel, name, value)
    channel.full_clean()
    channel.save()
    changed = audit_changes(before, audit_snapshot(channel, fields))
    if changed:
        _audit(channel, "channel.changed", by=by, changed=changed)
    return channel


@transaction.atomic
def notification_channel_delete(*, channel: NotificationChannel, by: str = "") -> None:
    """Delete a channel and the notifications owed to it; the rules lose it from their lists."""
    _audit(channel, "channel.deleted", by=by, target=channel.target)
    channel.delete()
