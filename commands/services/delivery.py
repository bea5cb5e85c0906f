"""Command delivery: claim (the boat's poll), ack, cancel, withdraw, expire, legacy hand-over."""

from __future__ import annotations

import datetime as dt
import uuid
from typing import Any

from django.db import transaction
from django.db.models import Q
from django.utils import timezone

from audit.services import audit_record
from commands.errors import CommandError, CommandNotFound, TransitionError
from commands.lifecycle import ACK_STATUSES, OPEN, Status, ack_is_stale, check_transition
from commands.models import Command, CommandEvent, Relay
from commands.services._transition import _storable_text, _transition
from vessels.models import Vessel

RELAYED = (Relay.SMS, Relay.SBD)


def command_expire_due(*, now: dt.datetime | None = None, vessel: Vessel | None = None) -> int:
    """Expire queued commands past their expires_at; return how many expired."""
    now = now or timezone.now()
    due = Command.objects.filter(status=Status.QUEUED, expires_at__lte=now)
    if vessel is not None:
        due = due.filter(vessel=vessel)
    count = 0
    for command in due:
        with transaction.atomic():
            count += _transition(
                command,
                Status.EXPIRED,
                now=now,
                actor="system",
                detail="not delivered before expires_at",
            )
    return count


def command_claim_open(
    *,
    vessel: Vessel,
    kinds: list[str] | None = None,
    now: dt.datetime | None = None,
    actor: str = "boat",
) -> list[Command]:
    """The vessel's open commands, oldest first, marking the queued ones as sent.

    Delivery is at-least-once: a sent command is offered again until the vessel acks it.
    Two polls racing each see every command, but each queued→sent happens once (see
    :func:`_transition`).
    """
    now = now or timezone.now()
    command_expire_due(now=now, vessel=vessel)
    open_commands = Command.objects.filter(
        vessel=vessel, status__in=[s.value for s in OPEN], reported=False
    )
    if kinds is not None:
        open_commands = open_commands.filter(kind__in=kinds)
    commands = list(open_commands.order_by("created_at", "pk"))
    queued = [c for c in commands if c.status == Status.QUEUED]
    if queued:
        with transaction.atomic():
            for command in queued:
                if not _transition(command, Status.SENT, now=now, actor=actor):
                    command.refresh_from_db(fields=["status", "sent_at"])
        # A lost race is either another poll (now sent: still offered) or a cancel,
        # supersede or expiry that committed after the list was read: never hand that out.
        commands = [c for c in commands if c.status in OPEN]
    return commands


def _get_for_vessel(vessel: Vessel, uid: Any) -> Command:
    try:
        return Command.objects.get(vessel=vessel, uid=uuid.UUID(str(uid)))
    except (ValueError, Command.DoesNotExist):
        # Another vessel's command is reported exactly like a missing one: a boat cannot
        # learn that a uid exists elsewhere.
        raise CommandNotFound(f"no command {uid} for this vessel") from None


DELIVERED_ELSEWHERE = "acknowledged by the vessel before any poll: delivered by another link"


@transaction.atomic
def command_ack(
    *,
    vessel: Vessel,
    uid: Any,
    status: str,
    detail: str = "",
    now: dt.datetime | None = None,
) -> tuple[Command, bool]:
    """Record the vessel's report on a command; return (command, changed).

    Idempotent: a repeated or stale ack (acknowledged after done) changes nothing. A queued
    command (no poll took it: it went by SBD or SMS) becomes sent, then takes the ack.
    Raises CommandNotFound, or TransitionError for an illegal report (done after cancelled,
    failed after done).
    """
    now = now or timezone.now()
    try:
        reported = Status(status)
    except ValueError:
        reported = None
    if reported not in ACK_STATUSES:
        *first, last = ACK_STATUSES
        raise CommandError(f"status must be {', '.join(first)} or {last}", field="status")
    command = _get_for_vessel(vessel, uid)
    for _attempt in range(4):  # a queued command takes one more step
        current = Status(command.status)
        if current == Status.QUEUED:
            # Not taken by a poll, yet the boat knows its uid: it came by another link (SBD,
            # SMS), which only learns of the delivery now. Sent first, as a poll would have.
            if not _transition(
                command, Status.SENT, now=now, actor="boat", detail=DELIVERED_ELSEWHERE
            ):
                command.refresh_from_db()
            continue
        if ack_is_stale(current, reported):
            return command, False
        if command.relay in RELAYED and current in (Status.CANCELLED, Status.EXPIRED):
            # Relayed by SMS or SBD, it reached the boat anyway: neither link can recall it
            # or carry its expiry. What the boat did goes in its history; the status stays.
            CommandEvent.objects.create(
                command=command,
                at=now,
                from_status=current,
                to_status=current,
                actor="boat",
                detail=_storable_text(
                    f"the boat reports {reported} (it had it by {command.relay} before it was "
                    f"{current})" + (f": {detail}" if detail else "")
                ),
            )
            return command, False
        check_transition(current, reported)  # raises TransitionError
        if _transition(command, reported, now=now, actor="boat", detail=_storable_text(detail)):
            return command, True
        command.refresh_from_db()
    raise TransitionError(Status(command.status), reported)


@transaction.atomic
def command_cancel(*, command: Command, actor: str, now: dt.datetime | None = None) -> Command:
    """Cancel a queued or sent command. A sent one may already have reached the boat.

    A command the vessel created itself and only reports up (``reported``) is the vessel's:
    cancelling it here would change nothing there, so it is refused.
    """
    now = now or timezone.now()
    if command.reported:
        raise CommandError(
            "this command was created on the vessel and is only reported here; cancel it there",
            field="status",
        )
    # Races with the boat poll (queued→sent) and acks: when the conditional UPDATE loses,
    # read the new status and try again from there (sent may still be cancelled; acknowledged
    # may not). Three tries: each loss means the command moved forward, and it can only move
    # forward a few times.
    for _attempt in range(3):
        command.refresh_from_db()
        current = command.status
        detail = "cancelled by operator"
        if command.status == Status.SENT:
            detail += " (it may already have reached the vessel)"
        if _transition(command, Status.CANCELLED, now=now, actor=actor, detail=detail):
            _audit_cancelled(command, actor, was=current, now=now)
            return command
    command.refresh_from_db()
    raise TransitionError(Status(command.status), Status.CANCELLED)


def _audit_cancelled(command: Command, actor: str, *, was: str, now: dt.datetime) -> None:
    vessel = command.vessel
    audit_record(
        action="command.cancelled",
        actor=actor,
        subject_type="command",
        subject_id=command.uid,
        subject=f"{command.kind} → {vessel.name}",
        vessel=vessel.slug,
        detail={"kind": command.kind, "was": was},
        now=now,
    )


def command_withdraw_queued(
    *, command: Command, actor: str, detail: str, now: dt.datetime | None = None
) -> bool:
    """Cancel ``command`` only while it is still queued here; True if it was withdrawn.

    For a relay that learns its upstream dropped a command (the glider's shore link): once the
    command has been taken (sent) it is on its way and stays, unlike :func:`command_cancel`.
    The conditional UPDATE races with the taker exactly as two polls do.
    """
    if command.status != Status.QUEUED:
        return False
    with transaction.atomic():
        return _transition(
            command, Status.CANCELLED, now=now or timezone.now(), actor=actor, detail=detail
        )


LEGACY_KINDS = ["move_to", "hold"]
LEGACY_DELIVERY_NOTE = "delivered to a legacy SPAB client; the old protocol has no ack"


def command_deliver_legacy(*, vessel: Vessel, now: dt.datetime | None = None) -> list[Command]:
    """Hand the open move_to/hold commands to an original SPAB client (GET requestCommands.cgi).

    The old protocol has no acknowledgement, so delivery counts as one: otherwise the old
    client would be handed (and would re-run) the same waypoint on every poll forever.
    """
    now = now or timezone.now()
    commands = command_claim_open(vessel=vessel, kinds=LEGACY_KINDS, now=now, actor="legacy")
    with transaction.atomic():
        for command in commands:
            if command.status == Status.SENT:
                _transition(
                    command,
                    Status.ACKNOWLEDGED,
                    now=now,
                    actor="legacy",
                    detail=LEGACY_DELIVERY_NOTE,
                )
    return commands


def command_relay_claim(
    *, command: Command, relay: str, was: str = "", now: dt.datetime | None = None
) -> bool:
    """Mark ``command`` as relayed by ``relay`` (a Relay) if it still stands at ``was`` and is
    still queued and unexpired; False when another router got there first, or the command was
    cancelled, expired or taken over HTTP meanwhile (a pass reads its list before it sends,
    and a text takes seconds). Claimed before the send, so two routers never send one command
    twice (at most once: a crash after the claim leaves it to HTTP)."""
    now = now or timezone.now()
    unexpired = Q(expires_at__isnull=True) | Q(expires_at__gt=now)
    claimed = Command.objects.filter(
        unexpired, pk=command.pk, relay=was, status=Status.QUEUED
    ).update(relay=relay, relayed_at=now)
    if claimed:
        command.relay, command.relayed_at = relay, now
    return bool(claimed)
