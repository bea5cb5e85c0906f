"""The one way to write the audit log. Callers are services (never views): they know what was
done; the request, when there is one, tells who and from where."""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.utils import timezone

from audit.models import ActorKind, AuditEntry

# Field lengths of AuditEntry: a long name is cut, never refused; the log must not fail the
# action it records.
_LIMITS = {"actor": 150, "via": 20, "action": 50, "subject_type": 50, "subject_id": 64,
           "subject": 200, "vessel": 50}  # fmt: skip


def audit_record(
    *,
    action: str,
    actor: str = "",
    actor_kind: str = ActorKind.OPERATOR,
    via: str = "",
    ip: str | None = None,
    subject_type: str = "",
    subject_id: object = "",
    subject: object = "",
    vessel: str = "",
    detail: dict[str, Any] | None = None,
    now: dt.datetime | None = None,
) -> AuditEntry:
    """Write one entry, in the caller's transaction (an action rolled back leaves no entry)."""
    fields = {
        "action": action, "actor": actor, "via": via, "subject_type": subject_type,
        "subject_id": str(subject_id), "subject": str(subject), "vessel": vessel,
    }  # fmt: skip
    fields = {name: value[: _LIMITS[name]] for name, value in fields.items()}
    return AuditEntry.objects.create(
        at=now or timezone.now(),
        actor_kind=actor_kind,
        ip=ip or None,
        detail=detail or {},
        **fields,
    )
