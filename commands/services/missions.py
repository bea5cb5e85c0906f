"""Missions as commands: what would refuse a mission, and sending one to a vessel."""

from __future__ import annotations

import datetime as dt
from typing import Any

from commands import catalog
from commands.errors import CatalogError, CommandError
from commands.models import Command, Source
from commands.services.enqueue import _mission_route_problems, command_enqueue
from vessels import missions
from vessels.models import Mission, Vessel


def mission_send_problems(*, mission: Mission, vessel: Vessel | None = None) -> list[str]:
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
    seen_at: dt.datetime | None = None,
) -> Command:
    """Queue ``mission`` as a `mission` command for ``vessel`` (default: the mission's own).
    Checked like every command (catalog, mission checks); raises CommandError.

    ``confirmed``, the route the operator confirmed (``{"end", "items"}``, as the planner
    showed it), must be the saved one, or nothing is sent: an unsaved edit on screen (or
    someone else's save since) never goes out as the saved route behind the operator's back.
    ``seen_at``, the mission's ``updated_at`` as the caller read it (a page, a summary, an API
    read), must still be its version: a save since (another route, another vessel) is refused.
    """
    if stale := missions.saved_since(mission.updated_at, seen_at):
        raise CommandError(stale, field="updated_at")
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
        audit_as={
            "action": "mission.sent",
            "subject_type": "mission",
            "subject_id": mission.pk,
            "subject": f"{mission.name} → {vessel.name}",
            "detail": {"mission": mission.name, "waypoints": len(params["items"])},
        },
    )
