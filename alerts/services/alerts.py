"""Alert episodes: open, resolve, acknowledge. Each queues the notifications its event owes in
the same transaction, and each is safe against a second evaluator doing the same at once."""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.db import IntegrityError, transaction
from django.utils import timezone

from alerts.models import ACTIVE_STATES, Alert, AlertRule, AlertState
from alerts.services.notifications import notifications_queue
from audit.services import audit_record

OPENED, ACKNOWLEDGED, RESOLVED = "alert.opened", "alert.acknowledged", "alert.resolved"


def alert_open(
    *,
    rule: AlertRule,
    vessel_id: int,
    subject: str = "",
    value: float | None = None,
    detail: str = "",
    fix_id: int | None = None,
    now: dt.datetime | None = None,
) -> Alert | None:
    """Open an episode of ``rule`` on the vessel (and subject) and queue its `alert.opened`
    notifications; None when one is already active.

    Races with another evaluator opening the same episode: the partial unique constraint
    ``alert_one_active_episode`` lets one INSERT in; the other's fails, rolls back its
    savepoint (its notifications with it) and answers None."""
    now = now or timezone.now()
    alert = Alert(
        rule=rule,
        vessel_id=vessel_id,
        kind=rule.kind,
        subject=subject,
        state=AlertState.OPEN,
        opened_at=now,
        value=value,
        detail=detail,
        fix_id=fix_id,
    )
    # The constraint is validated by the database, not here: full_clean would only ask the
    # same question racily first. So are the foreign keys (the caller read them from it): a
    # query each per alert is what a busy pass cannot afford (bench.alerts).
    alert.full_clean(exclude=["rule", "vessel", "fix"], validate_constraints=False)
    try:
        with transaction.atomic():
            alert.save()
            notifications_queue(alert=alert, event=OPENED, now=now)
    except IntegrityError:
        return None
    return alert


def alert_resolve(*, alert: Alert, now: dt.datetime | None = None, detail: str = "") -> bool:
    """Resolve an active episode and queue `alert.resolved`; False when it was not active
    (already resolved, by another evaluator racing this one: its conditional UPDATE won)."""
    now = now or timezone.now()
    with transaction.atomic():
        changes: dict[str, Any] = {"state": AlertState.RESOLVED, "resolved_at": now}
        won = Alert.objects.filter(pk=alert.pk, state__in=ACTIVE_STATES).update(**changes)
        if not won:
            return False
        alert.state, alert.resolved_at = AlertState.RESOLVED, now
        if detail:
            alert.detail = f"{alert.detail}\n{detail}".strip()
            Alert.objects.filter(pk=alert.pk).update(detail=alert.detail)
        notifications_queue(alert=alert, event=RESOLVED, now=now)
    return True


def alert_acknowledge(
    *,
    alert: Alert,
    by: Any,
    now: dt.datetime | None = None,
    via: str = "",
    ip: str | None = None,
) -> bool:
    """Acknowledge an open episode (who: ``by``, a user or a name): it stays active until its
    condition clears, but people know someone is on it. Writes the audit entry
    ``alert.acknowledged`` and queues `alert.acknowledged`; False when it was not open (already
    acknowledged or resolved: the conditional UPDATE lets one acknowledgement in)."""
    now = now or timezone.now()
    name = getattr(by, "get_username", lambda: str(by))()
    with transaction.atomic():
        won = Alert.objects.filter(pk=alert.pk, state=AlertState.OPEN).update(
            state=AlertState.ACKNOWLEDGED, acknowledged_at=now, acknowledged_by=name
        )
        if not won:
            return False
        alert.state, alert.acknowledged_at, alert.acknowledged_by = (
            AlertState.ACKNOWLEDGED,
            now,
            name,
        )
        audit_record(
            action="alert.acknowledged",
            actor=name,
            via=via,
            ip=ip,
            subject_type="alert",
            subject_id=alert.pk,
            subject=str(alert.rule),
            vessel=alert.vessel.slug,
            detail={"rule": alert.rule_id, "kind": alert.kind, "subject": alert.subject},
            now=now,
        )
        notifications_queue(alert=alert, event=ACKNOWLEDGED, now=now)
    return True
