"""The one way a command changes status (a conditional UPDATE and its event), shared by
every command service, and the cleaning of a boat's free text before it is stored."""

from __future__ import annotations

import datetime as dt
from typing import Any

from commands.lifecycle import FINAL, OPEN, Status, check_transition
from commands.models import Command, CommandEvent
from vessels.services import vessel_bump_commands_version
from vessels.text import replace_unstorable

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


def _storable_text(text: str, limit: int = 2000) -> str:
    """A boat's free text as the database can keep it: NUL (PostgreSQL refuses it) and lone
    surrogates (valid JSON escapes, but not UTF-8) become U+FFFD rather than a 500."""
    return replace_unstorable(text[:limit])
