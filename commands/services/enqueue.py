"""Command writes that queue: validate, enqueue, and the supersede of older navigation orders."""

from __future__ import annotations

import datetime as dt
import uuid
from collections.abc import Mapping, Sequence
from typing import Any

from django.conf import settings
from django.db import transaction
from django.db.models import F
from django.utils import timezone

from audit.models import ActorKind
from audit.services import audit_record
from commands import catalog, sql
from commands.errors import CatalogError, CommandError
from commands.lifecycle import Status, check_transition
from commands.models import Command, CommandEvent, Source
from vessels import missions
from vessels.models import Vessel


def command_validate(
    *,
    vessel: Vessel,
    kind: str,
    params: Any,
    expires_at: dt.datetime | None = None,
    now: dt.datetime | None = None,
) -> tuple[catalog.ValidCommand, dt.datetime]:
    """Every check :func:`command_enqueue` makes, without writing anything.

    Returns the catalog-normalised command and the effective expiry; raises CatalogError or
    CommandError. Forms call it from ``clean()`` so a refusal is a form error, not a 500.
    """
    now = now or timezone.now()
    valid = catalog.validate(kind, params, vessel_kind=vessel.kind, vessel=vessel_context(vessel))
    if valid.kind == "mission":
        found = _mission_route_problems(valid.params)
        if found:
            raise CatalogError("; ".join(found), field="items")
    if not vessel.active:
        raise CommandError(f"vessel {vessel.slug} is not active")
    if expires_at is None:
        expires_at = now + dt.timedelta(seconds=settings.COMMAND_DEFAULT_TTL_S)
    elif expires_at <= now:
        raise CommandError("expires_at must be in the future")
    return valid, expires_at


def vessel_context(vessel: Vessel) -> catalog.VesselContext:
    """What the catalog checks a command against beyond the vessel's kind: its last fix and
    its move_to limit (its own, else the site's MOVE_TO_MAX_M), read here because the catalog
    reads neither the database nor the settings."""
    fix = vessel.last_fix or {}
    lat, lon = fix.get("lat"), fix.get("lon")
    if vessel.move_to_max_m is None:
        limit, source = settings.MOVE_TO_MAX_M, "MOVE_TO_MAX_M"
    else:
        limit, source = vessel.move_to_max_m, f"{vessel.name}'s move_to limit"
    return catalog.VesselContext(
        name=vessel.name,
        position=(lat, lon) if lat is not None and lon is not None else None,
        move_to_max_m=limit,
        limit_source=source,
    )


def _mission_route_problems(params: dict[str, Any]) -> list[str]:
    # The catalog is pure and reads no settings: the configurable leg limit enters here.
    return missions.problems(
        params["items"], max_leg_m=settings.MISSION_MAX_LEG_M, end=params["end"]
    )


def command_enqueue(
    *,
    vessel: Vessel,
    kind: str,
    params: Any,
    source: str = Source.API,
    created_by: str = "",
    expires_at: dt.datetime | None = None,
    now: dt.datetime | None = None,
    uid: uuid.UUID | None = None,
    audit_as: Mapping[str, Any] | None = None,
    urgent: bool = False,
) -> Command:
    """Validate through the catalog and queue a command; raises CatalogError or CommandError.

    A new navigation command supersedes the vessel's older queued navigation commands: only
    the newest navigation order may reach the boat. ``uid`` keeps a command's identity from
    elsewhere (a glider queues its shore's commands under the shore's uid); a new one otherwise.

    The audit log gets a ``command.queued`` entry: ``created_by`` did it (a phone number for
    an SMS), through ``source``. ``audit_as`` (action, subject_type, subject_id, subject,
    detail) writes another entry instead, for a caller that sends something as a command
    (mission_send: ``mission.sent``): one entry naming what was sent, the command's uid in
    its detail.

    Every refusal is raised before the transaction starts, so a caller inside its own
    transaction (the SMS handling) can answer it and go on; the writes then need no savepoint
    of their own: the command, one conditional UPDATE for the superseded ones, one INSERT for
    all the events, one commands_version bump and the audit entry (4-5 statements).
    """
    now = now or timezone.now()
    valid, expires_at = command_validate(
        vessel=vessel, kind=kind, params=params, expires_at=expires_at, now=now
    )
    command = Command(
        vessel=vessel,
        kind=valid.kind,
        params=valid.params,
        source=source,
        created_by=created_by[:150],
        expires_at=expires_at,
        status=Status.QUEUED,
        urgent=urgent,
    )
    if uid is not None:
        command.uid = uid
    # The field checks without the foreign key's query (the vessel is the loaded row); the uid
    # is checked for uniqueness only when it comes from elsewhere (a fresh uuid4 cannot clash,
    # and the unique index still guards it).
    command.full_clean(
        exclude=["vessel"], validate_unique=uid is not None, validate_constraints=False
    )
    with transaction.atomic(savepoint=False):
        if valid.navigation:
            _serialise_navigation_enqueues(vessel.pk)
        command.save()
        if valid.navigation:
            _supersede_older_navigation(command, now)
        else:
            _record_enqueued(command, now)
        _audit_enqueued(command, vessel, now, audit_as or {})
    return command


# Who queues a command, by its source: a person at a screen or a script, else the phone.
_ACTOR_KIND = {Source.SMS: ActorKind.PHONE, Source.VESSEL: ActorKind.VESSEL}


def _audit_enqueued(
    command: Command, vessel: Vessel, now: dt.datetime, audit_as: Mapping[str, Any]
) -> None:
    entry: dict[str, Any] = {
        "action": "command.queued",
        "subject_type": "command",
        "subject_id": command.uid,
        "subject": f"{command.kind} → {vessel.name}",
        "detail": {
            "kind": command.kind,
            "params": _params_in_short(command.params),
            **({"urgent": True} if command.urgent else {}),
        },
    }
    if audit_as:
        entry |= audit_as
        entry["detail"] = {"command": str(command.uid), **audit_as.get("detail", {})}
    audit_record(
        **entry,
        actor=command.created_by,
        actor_kind=_ACTOR_KIND.get(command.source) if command.created_by else None,
        via=command.source,
        vessel=vessel.slug,
        now=now,
    )


def _params_in_short(params: dict[str, Any]) -> dict[str, Any]:
    """The parameters as the log keeps them: a mission's waypoints counted, not copied (the
    command keeps them; an entry stays small)."""
    return {
        name: f"{len(value)} items" if isinstance(value, list) else value
        for name, value in params.items()
    }


def _serialise_navigation_enqueues(vessel_id: int) -> None:
    """Make racing navigation enqueues for one vessel take turns, until the transaction ends
    (an advisory lock on PostgreSQL: why, in commands.sql.enqueue_lock)."""
    sql.enqueue_lock(vessel_id)


# The navigation kinds, for the supersede UPDATE.
_NAVIGATION_KINDS = tuple(k.name for k in catalog.KINDS.values() if k.navigation)


def _supersede_detail(command: Command) -> str:
    return f"superseded by {command.kind} {command.uid}"


def _record_enqueued(command: Command, now: dt.datetime, superseded: Sequence[int] = ()) -> None:
    """The events of an enqueue (the new command queued, the ``superseded`` ones) in one
    INSERT, and one commands_version bump per command that entered or left the boat's list
    in one UPDATE: the poll's ETag changes either way (as vessel_bump_commands_version)."""
    queued = CommandEvent(
        command=command,
        at=now,
        to_status=Status.QUEUED,
        actor=command.created_by,
        detail=f"via {command.source}",
    )
    detail = _supersede_detail(command)
    replaced = [
        CommandEvent(
            command_id=pk,
            at=now,
            from_status=Status.QUEUED.value,
            to_status=Status.SUPERSEDED.value,
            actor="system",
            detail=detail,
        )
        for pk in superseded
    ]
    CommandEvent.objects.bulk_create([queued, *replaced])
    Vessel.objects.filter(pk=command.vessel_id).update(
        commands_version=F("commands_version") + 1 + len(replaced)
    )


def _supersede_older_navigation(command: Command, now: dt.datetime) -> None:
    """Mark the vessel's other queued navigation commands superseded, then record the enqueue.

    One conditional UPDATE (commands.sql.queued_supersede) re-checks ``queued`` row by row,
    so a command a poll sent or an operator cancelled meanwhile is left alone, exactly as
    :func:`_transition` would, and only the rows it changed get an event.
    """
    check_transition(Status.QUEUED, Status.SUPERSEDED)
    superseded = sql.queued_supersede(
        vessel_id=command.vessel_id,
        kinds=_NAVIGATION_KINDS,
        keep=command.pk,
        now=now,
        detail=_supersede_detail(command),
    )
    _record_enqueued(command, now, superseded)
