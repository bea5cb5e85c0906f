"""Commands a vessel created itself and reports up (a glider's SMS commands)."""

from __future__ import annotations

import datetime as dt
import logging
import uuid
from collections.abc import Mapping, Sequence
from typing import Any

from django.conf import settings
from django.db import IntegrityError, transaction
from django.utils import timezone

from commands import catalog
from commands.errors import CommandError, TransitionError
from commands.lifecycle import FINAL, Status, check_transition
from commands.models import Command, CommandEvent, Source
from commands.services._transition import _STAMP, _storable_text, _transition
from edge_client.contract.batch import BatchAnswer
from vessels.batch import Unreadable
from vessels.clock import check_plausible
from vessels.models import Vessel

logger = logging.getLogger(__name__)


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


def command_reports_record(
    *, vessel: Vessel, reports: Sequence[Mapping[str, Any] | Unreadable]
) -> BatchAnswer:
    """Mirror a batch of the commands ``vessel`` created itself, each as it stands there now
    (:func:`command_record_reported`): new or moved forward counts as accepted; repeated,
    older, or one of the shore's own commands as a duplicate; an unreadable or refused report
    is rejected by its index, and never costs the others."""
    answer = BatchAnswer()
    for index, report in enumerate(reports):
        if isinstance(report, Unreadable):
            answer.reject(index, report.errors)
            continue
        try:
            _command, changed = command_record_reported(vessel=vessel, **report)
        except CommandError as exc:
            answer.reject(index, exc.as_dict())
            continue
        except IntegrityError:
            changed = False  # the same report racing itself: the other one stored it
        if changed:
            answer.accepted += 1
        else:
            answer.duplicates += 1
    return answer
