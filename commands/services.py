"""Command writes: enqueue, claim (deliver), ack, cancel, expire. Every transition is recorded."""

from __future__ import annotations

import datetime as dt
import logging
import re
import uuid
from collections.abc import Sequence
from typing import Any

from django.conf import settings
from django.db import connection, transaction
from django.db.models import F
from django.utils import timezone

from commands import catalog
from commands.errors import CatalogError, CommandError, CommandNotFound, TransitionError
from commands.lifecycle import (
    ACK_STATUSES,
    FINAL,
    OPEN,
    Status,
    ack_is_stale,
    check_transition,
)
from commands.models import Command, CommandEvent, Source
from vessels import missions
from vessels.clock import check_plausible
from vessels.models import Mission, Vessel
from vessels.services import vessel_bump_commands_version

logger = logging.getLogger(__name__)

# Which timestamp field each status sets.
_STAMP = {
    Status.SENT: "sent_at",
    Status.ACKNOWLEDGED: "acknowledged_at",
    Status.DONE: "finished_at",
    Status.FAILED: "finished_at",
    Status.CANCELLED: "finished_at",
    Status.SUPERSEDED: "finished_at",
    Status.EXPIRED: "finished_at",
}
# The boat poll lists the OPEN statuses; moving to any other changes its list (and ETag).
_LEAVES_BOAT_LIST = frozenset(Status) - frozenset(OPEN)


# First key of the two-key PostgreSQL advisory lock that serialises navigation enqueues.
_ENQUEUE_LOCK_SPACE = 0x5353  # "SS", Shoreside

# NUL and the UTF-16 surrogate range: neither can be stored as text on PostgreSQL.
_UNSTORABLE = re.compile("[\x00\ud800-\udfff]")


def _transition(
    command: Command,
    target: Status,
    *,
    now: dt.datetime,
    actor: str = "",
    detail: str = "",
    bump: bool = True,
    fields: dict[str, Any] | None = None,
) -> bool:
    """Move ``command`` from its current status to ``target`` if nobody else moved it first.

    The UPDATE is conditional on the status we read, so of two racing callers (two polls,
    a poll and a cancel) exactly one wins, on SQLite and PostgreSQL alike; only the winner
    records the transition. ``fields``: the event's machine state (CommandEvent.cc_code …).
    """
    current = Status(command.status)
    check_transition(current, target)
    changes: dict[str, Any] = {"status": target.value}
    if stamp := _STAMP.get(target):
        changes[stamp] = now
    if detail and target in FINAL:
        changes["result_detail"] = detail
    won = Command.objects.filter(pk=command.pk, status=current.value).update(**changes) == 1
    if not won:
        return False
    for name, value in changes.items():
        setattr(command, name, value)
    CommandEvent.objects.create(
        command=command,
        at=now,
        from_status=current.value,
        to_status=target.value,
        actor=actor,
        detail=detail,
        **(fields or {}),
    )
    if bump and target in _LEAVES_BOAT_LIST:
        vessel_bump_commands_version(vessel_id=command.vessel_id)
    return True


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


def mission_problems(*, mission: Mission, vessel: Vessel | None = None) -> list[str]:
    """Every reason sending ``mission`` (to ``vessel``, default its own) would be refused by
    the catalog or the mission checks, [] when none. Writes nothing: the admin shows these
    when a mission is saved."""
    vessel = vessel or mission.vessel
    try:
        valid = catalog.validate(
            "mission", mission.as_params(), vessel_kind=vessel.kind if vessel else None
        )
    except CatalogError as exc:
        return [exc.message]
    return _mission_route_problems(valid.params)


_UNCONFIRMED = object()  # mission_send without a confirmed route: the API, the list's action


def mission_send(
    *,
    mission: Mission,
    vessel: Vessel | None = None,
    source: str = Source.API,
    created_by: str = "",
    now: dt.datetime | None = None,
    confirmed: Any = _UNCONFIRMED,
) -> Command:
    """Queue ``mission`` as a `mission` command for ``vessel`` (default: the mission's own).
    Checked like every command (catalog, mission checks); raises CommandError.

    ``confirmed``, the route the operator confirmed (``{"end", "items"}``, as the planner
    showed it), must be the saved one, or nothing is sent: an unsaved edit on screen (or
    someone else's save since) never goes out as the saved route behind the operator's back."""
    vessel = vessel or mission.vessel
    if vessel is None:
        raise CommandError("a template has no vessel; copy it to one.", field="vessel")
    params = mission.as_params()
    if confirmed is not _UNCONFIRMED:
        differs = missions.mismatch(params["items"], params["end"], shown=confirmed)
        if differs:
            raise CommandError(
                f"not sent: the mission on screen is not the one saved ({differs}); save it "
                "(or reload the page) and send again"
            )
    return command_enqueue(
        vessel=vessel,
        kind="mission",
        params=params,
        source=source,
        created_by=created_by,
        now=now,
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
) -> Command:
    """Validate through the catalog and queue a command; raises CatalogError or CommandError.

    A new navigation command supersedes the vessel's older queued navigation commands: only
    the newest navigation order may reach the boat. ``uid`` keeps a command's identity from
    elsewhere (a glider queues its shore's commands under the shore's uid); a new one otherwise.

    Every refusal is raised before the transaction starts, so a caller inside its own
    transaction (the SMS handling) can answer it and go on; the writes then need no savepoint
    of their own: the command, one conditional UPDATE for the superseded ones, one INSERT for
    all the events and one commands_version bump (3-4 statements).
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
    return command


def _serialise_navigation_enqueues(vessel_id: int) -> None:
    """Make racing navigation enqueues for one vessel take turns, until the transaction ends.

    Under PostgreSQL's READ COMMITTED, two racing enqueues each looked for older queued
    navigation commands before the other had committed, and both stayed queued. A row lock
    on the vessel would invert the lock order of cancel/ack (command row, then the vessel's
    commands_version) and deadlock with them; an advisory lock only enqueues take cannot.
    SQLite needs nothing: its IMMEDIATE transactions already run one at a time.
    """
    if connection.vendor == "postgresql":
        with connection.cursor() as cursor:
            cursor.execute(
                "SELECT pg_advisory_xact_lock(%s, %s)",
                [_ENQUEUE_LOCK_SPACE, vessel_id & 0x7FFFFFFF],
            )


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

    One conditional UPDATE … RETURNING (PostgreSQL; SQLite >= 3.35) instead of a read and an
    update per command: the WHERE re-checks ``queued`` row by row (on PostgreSQL after any
    lock wait), so a command a poll sent or an operator cancelled meanwhile is left alone,
    exactly as :func:`_transition` would, and only the rows it changed get an event.
    """
    check_transition(Status.QUEUED, Status.SUPERSEDED)
    table = connection.ops.quote_name(Command._meta.db_table)
    kinds = ", ".join(["%s"] * len(_NAVIGATION_KINDS))
    with connection.cursor() as cursor:
        cursor.execute(
            f"UPDATE {table} SET status = %s, finished_at = %s, result_detail = %s "
            f"WHERE vessel_id = %s AND status = %s AND kind IN ({kinds}) AND id <> %s "
            # A command the vessel made itself and only reports up is the vessel's to change.
            "AND reported = %s RETURNING id",
            [
                Status.SUPERSEDED.value,
                connection.ops.adapt_datetimefield_value(now),
                _supersede_detail(command),
                command.vessel_id,
                Status.QUEUED.value,
                *_NAVIGATION_KINDS,
                command.pk,
                False,
            ],
        )
        superseded = sorted(row[0] for row in cursor.fetchall())
    _record_enqueued(command, now, superseded)


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


def _storable_text(text: str, limit: int = 2000) -> str:
    """A boat's free text as the database can keep it: NUL (PostgreSQL refuses it) and lone
    surrogates (valid JSON escapes, but not UTF-8) become U+FFFD rather than a 500."""
    return _UNSTORABLE.sub("\ufffd", text[:limit])


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

    Idempotent: a repeated or stale ack (acknowledged after done) changes nothing.
    Raises CommandNotFound, or TransitionError for an illegal report (done after cancelled,
    failed after done).
    """
    now = now or timezone.now()
    try:
        reported = Status(status)
    except ValueError:
        reported = None
    if reported not in ACK_STATUSES:
        raise CommandError(
            "status must be acknowledged, done, failed or superseded", field="status"
        )
    command = _get_for_vessel(vessel, uid)
    for _attempt in range(3):
        current = Status(command.status)
        if ack_is_stale(current, reported):
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
        detail = "cancelled by operator"
        if command.status == Status.SENT:
            detail += " (it may already have reached the vessel)"
        if _transition(command, Status.CANCELLED, now=now, actor=actor, detail=detail):
            return command
    command.refresh_from_db()
    raise TransitionError(Status(command.status), Status.CANCELLED)


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
    """Hand the open move_to/hold commands to a thesis-era client (GET requestCommands.cgi).

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


# --- for transports that hand commands over one at a time (the Wave Glider bridge) ----------


@transaction.atomic
def command_mark_sent(
    *,
    command: Command,
    actor: str,
    detail: str = "",
    now: dt.datetime | None = None,
    tid: int | None = None,
    src_task: int | None = None,
    src_board: int | None = None,
) -> bool:
    """queued → sent for a command being handed over now; False if it moved first.

    The conditional UPDATE (see :func:`_transition`) makes a racing cancel, supersede or
    expiry win cleanly: the caller must then not hand the command over. ``tid``, ``src_task``
    and ``src_board`` name the request that took it (kept on the sent event).
    """
    request = {"tid": tid, "src_task": src_task, "src_board": src_board}
    return _transition(
        command, Status.SENT, now=now or timezone.now(), actor=actor, detail=detail, fields=request
    )


@transaction.atomic
def command_fail_unsent(
    *,
    command: Command,
    reason: str,
    actor: str,
    now: dt.datetime | None = None,
    cc_reason: str = "",
) -> bool:
    """Fail a queued command its transport refuses to send, with the reason; False if it moved.

    The lifecycle (DESIGN §4) has no queued → failed, so the command passes through sent in
    this one transaction: nobody outside ever sees it sent, and the sent event says that
    nothing was handed over. ``cc_reason`` (the failed event's) is the refusal as a reply
    says it.
    """
    now = now or timezone.now()
    if not _transition(
        command, Status.SENT, now=now, actor=actor, detail=f"not handed over: {reason}"
    ):
        return False
    return _transition(
        command,
        Status.FAILED,
        now=now,
        actor=actor,
        detail=reason,
        fields={"cc_reason": _storable_text(cc_reason)},
    )


@transaction.atomic
def command_complete(
    *,
    command: Command,
    status: str,
    detail: str,
    actor: str,
    now: dt.datetime | None = None,
    cc_code: int | None = None,
    cc_reason: str = "",
) -> bool:
    """Record the final answer on a handed-over command: ``done`` or ``failed``.

    ``done`` goes sent → acknowledged → done (a single ACK both accepts and completes it),
    ``failed`` goes straight to failed. Returns False, changing nothing, when the command is
    no longer sent or acknowledged (an operator cancelled it meanwhile, or it already ended).
    ``cc_code`` and ``cc_reason``, the answer itself, go on its events beside ``detail``.
    """
    target = Status(status)
    if target not in (Status.DONE, Status.FAILED):
        raise CommandError("status must be done or failed", field="status")
    now = now or timezone.now()
    answer = {"cc_code": cc_code, "cc_reason": _storable_text(cc_reason)}
    command.refresh_from_db(fields=["status"])
    if command.status == Status.SENT and target == Status.DONE:
        if not _transition(
            command, Status.ACKNOWLEDGED, now=now, actor=actor, detail=detail, fields=answer
        ):
            return False
    if command.status not in (Status.SENT, Status.ACKNOWLEDGED):
        return False
    return _transition(command, target, now=now, actor=actor, detail=detail, fields=answer)


def command_note(
    *, command: Command, detail: str, actor: str, now: dt.datetime | None = None
) -> CommandEvent:
    """Log what happened to a command without changing its status (from = to = current).

    For facts an operator must see in the command's log that are not transitions: a late
    answer after a timeout, a retry answered again after a restart.
    """
    command.refresh_from_db(fields=["status"])
    return CommandEvent.objects.create(
        command=command,
        at=now or timezone.now(),
        from_status=command.status,
        to_status=command.status,
        actor=actor[:150],
        detail=_storable_text(detail),
    )


# --- commands a vessel created itself and reports up (a glider's SMS commands) ---------------

REPORTED_ACTOR = "vessel"
# How far along a command is, to tell a report that moves it forward from an old or repeated
# one (reports travel through a store-and-forward outbox, out of order after a restart).
_REPORT_RANK = {Status.QUEUED: 0, Status.SENT: 1, Status.ACKNOWLEDGED: 2}
_FINAL_RANK = 3


def _reported_path(
    current: Status, target: Status, *, sent: bool, acknowledged: bool
) -> list[Status]:
    """The statuses a reported command passes through from ``current`` to ``target``: through
    sent (and acknowledged) when the vessel says it got that far, so each one has its event."""
    path: list[Status] = []
    goes_out = target in (Status.SENT, Status.ACKNOWLEDGED, Status.DONE, Status.FAILED) or sent
    if current == Status.QUEUED and goes_out and target != Status.QUEUED:
        path.append(Status.SENT)
    wants_ack = target == Status.ACKNOWLEDGED or (
        acknowledged and target in (Status.DONE, Status.FAILED)
    )
    if current in (Status.QUEUED, Status.SENT) and wants_ack:
        path.append(Status.ACKNOWLEDGED)
    if target != (path[-1] if path else current):
        path.append(target)
    return path


def _advance_reported(
    command: Command, path: list[Status], *, stamps: dict[str, Any], detail: str, now: dt.datetime
) -> None:
    """Move a reported command along ``path`` with the vessel's own times. Unlike the other
    transitions it never bumps commands_version: the boat poll never lists it."""
    for target in path:
        stamp = _STAMP.get(target)
        at = (stamps.get(stamp) if stamp else None) or now
        note = detail if target in FINAL else "reported by the vessel"
        if not _transition(command, target, now=at, actor=REPORTED_ACTOR, detail=note, bump=False):
            raise TransitionError(Status(command.status), target)  # a racing report; it re-sends


def _report_rank(status: Status) -> int:
    return _REPORT_RANK.get(status, _FINAL_RANK)


# A vessel reports only what was made on board: by SMS, or by the vessel itself.
REPORTED_SOURCES = (Source.SMS.value, Source.VESSEL.value)
# "vessel" was called "system" before issue 16; a vessel that still says so means the same.
REPORTED_SOURCE_ALIASES = {"system": Source.VESSEL.value}
CREATED_BY_MAX = 150  # Command.created_by's max_length


def _reported_by(vessel: Vessel, said: str) -> str:
    """``vessel:<slug>/`` and what the vessel says: a vessel's word never passes for an
    operator's name in the audit trail."""
    prefix = f"vessel:{vessel.slug}/"
    return prefix + _storable_text(said, CREATED_BY_MAX - len(prefix))


def _check_reported_times(stamps: dict[str, dt.datetime | None], *, now: dt.datetime) -> None:
    """Each given stamp plausible (telemetry's rule) and in the order of the lifecycle:
    created_at <= sent_at <= acknowledged_at <= finished_at; CommandError names the field."""
    earlier: tuple[str, dt.datetime] | None = None
    for name, when in stamps.items():
        if when is None:
            continue
        try:
            check_plausible(when, now=now, max_future_s=settings.FIX_MAX_FUTURE_S)
        except ValueError as exc:
            raise CommandError(f"{name} {exc}", field=name) from None
        if earlier is not None and when < earlier[1]:
            raise CommandError(f"{name} is before {earlier[0]}", field=name)
        earlier = (name, when)


@transaction.atomic
def command_record_reported(
    *,
    vessel: Vessel,
    uid: uuid.UUID,
    kind: str,
    params: Any,
    status: str,
    source: str = Source.SMS,
    created_by: str = "",
    created_at: dt.datetime | None = None,
    sent_at: dt.datetime | None = None,
    acknowledged_at: dt.datetime | None = None,
    finished_at: dt.datetime | None = None,
    result_detail: str = "",
    now: dt.datetime | None = None,
) -> tuple[Command, bool]:
    """Mirror a command the vessel created itself (a glider's SMS command); (command, changed).

    An unknown uid becomes a ``reported`` command of ``vessel``, checked by the catalog for
    the vessel's kind, with an event per status it went through (actor "vessel"). A known
    reported uid moves forward to ``status``; a repeated or older report changes nothing. The
    shore's own commands are left alone (their acks carry their state): unchanged. Another
    vessel's uid is answered as an unknown one would be, and nothing is written. Raises
    CatalogError, CommandError or TransitionError (an illegal move).
    """
    now = now or timezone.now()
    try:
        reported = Status(status)
    except ValueError:
        raise CommandError(f"unknown status {status!r}", field="status") from None
    source = REPORTED_SOURCE_ALIASES.get(source, source)
    if source not in REPORTED_SOURCES:
        # An operator's command is made on the shore, never reported by a vessel's key.
        raise CommandError(
            f"a reported command comes from {' or '.join(REPORTED_SOURCES)}", field="source"
        )
    stamps = {"sent_at": sent_at, "acknowledged_at": acknowledged_at, "finished_at": finished_at}
    _check_reported_times({"created_at": created_at, **stamps}, now=now)
    detail = _storable_text(result_detail)
    existing = Command.objects.select_for_update().filter(uid=uid).first()
    # Another vessel's uid goes through the checks of an unknown uid and is answered the same
    # (changed), but nothing is written: a boat cannot learn that a uid exists elsewhere, as
    # with acks (_get_for_vessel). A random uid never collides by chance; it is a fault or a
    # probe, logged for the operators.
    foreign = existing is not None and existing.vessel_id != vessel.pk
    if existing is not None and not foreign:
        if not existing.reported:
            return existing, False
        current = Status(existing.status)
        if _report_rank(reported) < _report_rank(current) or reported == current:
            return existing, False
        path = _reported_path(
            current, reported, sent=sent_at is not None, acknowledged=acknowledged_at is not None
        )
        _advance_reported(existing, path, stamps=stamps, detail=detail, now=now)
        return existing, True
    valid = catalog.validate(kind, params, vessel_kind=vessel.kind)
    created = created_at or now
    command = Command(
        uid=uid,
        vessel=vessel,
        kind=valid.kind,
        params=valid.params,
        source=source,
        created_by=_reported_by(vessel, created_by),
        status=Status.QUEUED,
        reported=True,
    )
    command.full_clean(validate_unique=not foreign)
    path = _reported_path(
        Status.QUEUED, reported, sent=sent_at is not None, acknowledged=acknowledged_at is not None
    )
    for step_from, step_to in zip([Status.QUEUED, *path], path, strict=False):
        check_transition(step_from, step_to)  # before writing: an illegal report leaves nothing
    if foreign:
        logger.warning("%s reported another vessel's command uid %s: ignored", vessel.slug, uid)
        return command, True
    command.save()
    # created_at is auto_now_add: the vessel's own time is written after the insert.
    Command.objects.filter(pk=command.pk).update(created_at=created)
    command.created_at = created
    CommandEvent.objects.create(
        command=command,
        at=created,
        to_status=Status.QUEUED,
        actor=REPORTED_ACTOR,
        detail=f"reported by the vessel (via {source})",
    )
    _advance_reported(command, path, stamps=stamps, detail=detail, now=now)
    return command, True
