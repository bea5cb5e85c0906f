"""The one way to write the audit log. Callers are services (never views): they know what was
done; the origin in force (audit.context: a request's, a management command's) tells who and
from where whenever the service was not told."""

from __future__ import annotations

import datetime as dt
import ipaddress
from collections.abc import Iterable, Mapping
from typing import Any

from django.utils import timezone

from audit.context import current_origin
from audit.models import ActorKind, AuditEntry

# Field lengths of AuditEntry: a long name is cut, never refused; the log must not fail the
# action it records.
_LIMITS = {"actor": 150, "via": 20, "action": 50, "subject_type": 50, "subject_id": 64,
           "subject": 200, "vessel": 50}  # fmt: skip


def audit_record(
    *,
    action: str,
    actor: str = "",
    actor_kind: str | None = None,
    via: str = "",
    ip: str | None = None,
    subject_type: str = "",
    subject_id: object = "",
    subject: object = "",
    vessel: str = "",
    detail: dict[str, Any] | None = None,
    now: dt.datetime | None = None,
) -> AuditEntry:
    """Write one entry, in the caller's transaction (an action rolled back leaves no entry).

    What the caller leaves blank comes from the origin in force (audit.context): the actor
    (and its kind) when no ``actor`` is given, the kind when the actor given is the origin's,
    the way in when no ``via``, and the client's address for an operator when no ``ip``.
    Otherwise the kind is operator.
    """
    origin = current_origin()
    if not actor or (actor == origin.actor and actor_kind is None):
        actor, actor_kind = origin.actor, actor_kind or origin.actor_kind
    actor_kind = actor_kind or ActorKind.OPERATOR
    if ip is None and actor_kind == ActorKind.OPERATOR:
        ip = origin.ip
    fields = {
        "action": action, "actor": actor, "via": via or origin.via, "subject_type": subject_type,
        "subject_id": str(subject_id), "subject": str(subject), "vessel": vessel,
    }  # fmt: skip
    fields = {name: value[: _LIMITS[name]] for name, value in fields.items()}
    return AuditEntry.objects.create(
        at=now or timezone.now(),
        actor_kind=actor_kind,
        ip=_address(ip),
        detail=detail or {},
        **fields,
    )


def _address(ip: str | None) -> str | None:
    """``ip`` if it is an IP address, else None: a proxy's odd X-Forwarded-For hop
    ("unknown", a port) must not fail the action (PostgreSQL's inet column would refuse it)."""
    try:
        return str(ipaddress.ip_address((ip or "").strip().strip("[]")))
    except ValueError:
        return None


def audit_value(value: Any) -> Any:
    """A field's value as an entry's JSON holds it: a related row by its slug, else its id."""
    if hasattr(value, "slug"):
        return value.slug
    if hasattr(value, "pk"):
        return value.pk
    return value


def audit_snapshot(obj: object, names: Iterable[str]) -> dict[str, Any]:
    """``names`` of ``obj`` as audit values, to compare before and after a change."""
    return {name: audit_value(getattr(obj, name)) for name in names}


def audit_changes(before: Mapping[str, Any], after: Mapping[str, Any]) -> dict[str, Any]:
    """``{field: {"from", "to"}}`` for each field whose value differs; {} when none did."""
    return {k: {"from": before[k], "to": after[k]} for k in after if before[k] != after[k]}
