"""SMS-side reads: what the vessel is known to be doing, for queries and #STATUS."""

from __future__ import annotations

from dataclasses import dataclass

from commands import catalog
from commands.lifecycle import OPEN, Status
from commands.models import Command
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
