"""SMS-side reads: what the vessel is known to be doing, for queries and #STATUS; and every
read of the glider bridge (sms.bridge), which goes through here."""

from __future__ import annotations

import datetime as dt
import uuid
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from django.db.models import Q, QuerySet

from commands import catalog
from commands.lifecycle import OPEN, Status
from commands.models import Command, CommandEvent, Source
from sms.models import AuthorisedNumber, SmsMessage
from telemetry.models import Fix
from vessels.models import Vessel

# What the vessel is taken to be doing: it has the command (sent), took it (acknowledged) or
# carried it out (done). Queued ones are plans, not state.
KNOWN = (Status.SENT, Status.ACKNOWLEDGED, Status.DONE)
# A navigation order still in force or about to be: not replaced, cancelled or expired.
CURRENT_NAVIGATION = (*KNOWN, Status.QUEUED, Status.FAILED)
NAVIGATION_KINDS = [k.name for k in catalog.KINDS.values() if k.navigation]


@dataclass(frozen=True, slots=True)
class CommandState:
    """The newest command of one kind the vessel knows of, and a newer one still queued."""

    known: Command | None
    queued: Command | None


# Newest first by primary key (ids grow with created_at): SQLite walks the vessel index, whose
# equal keys are in rowid order, backwards and stops at the first match; ordering by created_at
# sorted every command the vessel ever had, on each SMS query.
NEWEST = "-pk"


def command_state(*, vessel: Vessel, kind: str) -> CommandState:
    newest = Command.objects.filter(vessel=vessel, kind=kind).order_by(NEWEST)
    return CommandState(
        known=newest.filter(status__in=KNOWN).first(),
        queued=newest.filter(status=Status.QUEUED).first(),
    )


def navigation_current(*, vessel: Vessel) -> Command | None:
    """The newest navigation order for the vessel that nothing replaced, cancelled or expired."""
    return (
        Command.objects.filter(
            vessel=vessel, kind__in=NAVIGATION_KINDS, status__in=CURRENT_NAVIGATION
        )
        .order_by(NEWEST)
        .first()
    )


def commands_pending(*, vessel: Vessel) -> int:
    """Commands the vessel still has to take (queued or sent, not yet acknowledged)."""
    return Command.objects.filter(vessel=vessel, status__in=[s.value for s in OPEN]).count()


# -- The glider bridge's reads (sms.bridge): its database is the glider's own -------------------


def bridge_vessel(slug: str) -> Vessel:
    """The bridge's vessel (Vessel.DoesNotExist if there is none: the command says so)."""
    return Vessel.objects.get(slug=slug)


def bridge_command(pk: int) -> Command:
    """One command by id (the bridge holds ids across threads, never instances)."""
    return Command.objects.get(pk=pk)


def bridge_commands_waiting(*, vessel_id: int, now: dt.datetime) -> QuerySet[Command]:
    """The vessel's queued, unexpired commands: the ORM's form of sms.sql's queued reads, used
    when their index cannot be. status IN (open) repeats the condition of the partial index
    command_open_by_vessel (vessel, created_at), so the planner can use it; status = queued
    then narrows."""
    return (
        Command.objects.filter(vessel_id=vessel_id, status__in=[s.value for s in OPEN])
        .filter(status=Status.QUEUED)
        .filter(Q(expires_at__isnull=True) | Q(expires_at__gt=now))
    )


def bridge_commands_sent(*, vessel_id: int) -> list[Command]:
    """The vessel's commands handed over and not answered yet, newest first."""
    return list(
        Command.objects.filter(vessel_id=vessel_id, status=Status.SENT).order_by("-sent_at", "-pk")
    )


def bridge_last_timeout(
    *, vessel_id: int, actor: str, detail: str, since: dt.datetime
) -> CommandEvent | None:
    """The newest event after ``since`` by which ``actor`` failed one of the vessel's commands
    with ``detail`` (the bridge's "no answer"), with its command."""
    return (
        CommandEvent.objects.filter(
            command__vessel_id=vessel_id,
            to_status=Status.FAILED,
            actor=actor,
            detail=detail,
            at__gt=since,
        )
        .select_related("command")
        .order_by("-at", "-pk")
        .first()
    )


def bridge_handover_event(*, command: Command, actor: str) -> CommandEvent | None:
    """The newest event by which ``actor`` marked ``command`` sent (its handover)."""
    return (
        CommandEvent.objects.filter(command=command, to_status=Status.SENT, actor=actor)
        .exclude(from_status=Status.SENT)
        .order_by("-at", "-pk")
        .first()
    )


def bridge_fixes_after(*, vessel: Vessel, after: int, limit: int) -> list[Fix]:
    """The vessel's next ``limit`` fixes by id after ``after`` (the upload's watermark)."""
    return list(Fix.objects.filter(vessel=vessel, pk__gt=after).order_by("pk")[:limit])


def bridge_commands_queued_by(*, vessel: Vessel, created_by: str) -> QuerySet[Command]:
    """The vessel's queued commands that ``created_by`` made (the shore's, taken here)."""
    return Command.objects.filter(vessel=vessel, created_by=created_by, status=Status.QUEUED)


def bridge_shore_commands_by_sms_after(
    *, vessel: Vessel, created_by: str, after: int, limit: int = 100
) -> list[tuple[int, uuid.UUID, str]]:
    """(id, uid, kind) of the vessel's commands ``created_by`` made from an SMS (the shore's
    commands that came by SMS with its reference), by id after ``after``."""
    found = Command.objects.filter(
        vessel=vessel, created_by=created_by, source=Source.SMS, pk__gt=after
    ).order_by("pk")
    return list(found.values_list("pk", "uid", "kind")[:limit])


def bridge_command_vessel(*, uid: uuid.UUID) -> int | None:
    """The id of the vessel whose command has ``uid`` (None: no command has it)."""
    return Command.objects.filter(uid=uid).values_list("vessel_id", flat=True).first()


def bridge_command_said(*, uid: uuid.UUID) -> tuple[str, dict[str, Any]] | None:
    """The kind and params of the command with ``uid`` (None: no command has it)."""
    return Command.objects.filter(uid=uid).values_list("kind", "params").first()


def bridge_commands_by_uid(uids: Iterable[str]) -> dict[str, Command]:
    """The commands with these uids, by uid as text (status and result only)."""
    found = Command.objects.filter(uid__in=list(uids)).only("uid", "status", "result_detail")
    return {str(command.uid): command for command in found}


def bridge_reported_commands_after(
    *, vessel: Vessel, after: int, not_by: str, limit: int
) -> tuple[int | None, list[Command]]:
    """The next ``limit`` events of the vessel's commands by id after ``after`` (the report's
    watermark), leaving out commands ``not_by`` made: (the last event's id, their commands by
    id), or (None, []) when there is none."""
    events = list(
        CommandEvent.objects.filter(command__vessel=vessel, pk__gt=after)
        .exclude(command__created_by=not_by)
        .order_by("pk")
        .values_list("pk", "command_id")[:limit]
    )
    if not events:
        return None, []
    commands = Command.objects.filter(pk__in={c for _, c in events}).order_by("pk")
    return events[-1][0], list(commands)


def bridge_sms_after(*, vessel: Vessel, after: int, limit: int) -> list[SmsMessage]:
    """The vessel's next ``limit`` SMS log entries by id after ``after``, with their commands."""
    return list(
        SmsMessage.objects.filter(vessel=vessel, pk__gt=after)
        .prefetch_related("commands")
        .order_by("pk")[:limit]
    )


# The prefix of a position SMS's delivery_key (sms.services.positions): one per vessel, number
# and fix.
POSITION_KEY_PREFIX = "pos:"


def bridge_position_recipients(*, vessel: Vessel, now: dt.datetime) -> list[AuthorisedNumber]:
    """The numbers that get the vessel's position SMS: active, unexpired, flagged."""
    return list(
        AuthorisedNumber.objects.filter(vessels=vessel, active=True, receives_positions=True)
        .filter(Q(expires_at__isnull=True) | Q(expires_at__gt=now))
        .order_by("number")
    )


def bridge_last_position_sms(*, vessel: Vessel) -> SmsMessage | None:
    """The vessel's newest position SMS (the schedule's place after a restart)."""
    return (
        SmsMessage.objects.filter(
            vessel=vessel,
            direction="out",
            delivery_key__startswith=f"{POSITION_KEY_PREFIX}{vessel.pk}:",
        )
        .order_by("-created_at", "-pk")
        .first()
    )


def bridge_vessel_last_fix(*, vessel: Vessel) -> Vessel:
    """The vessel's name and last fix, read afresh (the fix batches advance it)."""
    return Vessel.objects.only("name", "slug", "last_fix", "last_fix_at").get(pk=vessel.pk)
