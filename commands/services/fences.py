"""Fences as commands: the set a vessel's autopilot is to hold, and sending it (issue 19 §4).

An ArduPilot autopilot holds one fence set, and an upload replaces the whole of it; so a
`fence` command always carries every fence that applies to the vessel (its own and the
every-vessel ones), whichever fence the operator sent from.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.db.models import Q

from commands.errors import CatalogError, CommandError
from commands.models import Command, Source
from commands.services.enqueue import command_enqueue
from edge_client.contract import fence as shape
from edge_client.contract.kinds import MAVLINK
from vessels.models import Fence, Vessel


def fence_set_for(*, vessel: Vessel) -> list[Fence]:
    """The fences that apply to ``vessel``: its own and every vessel's, by name (then id,
    so the order, and the items the autopilot is sent, are the same every time)."""
    own_or_all = Q(vessel__isnull=True) | Q(vessel=vessel)
    return list(Fence.objects.filter(own_or_all).order_by("name", "pk"))


def fence_set_params(*, vessel: Vessel) -> dict[str, Any]:
    """The `fence` command's params for ``vessel``: ``{"fences": [...]}`` in the wire shape
    (edge_client.contract.fence). Raises CatalogError when a fence cannot be sent as it is, or
    when there is none."""
    wire = []
    for fence in fence_set_for(vessel=vessel):
        try:
            wire.append(
                shape.wire_fence(
                    id=fence.pk,
                    name=fence.name,
                    inclusion=fence.inclusion,
                    geometry=fence.geometry,
                    radius_m=fence.radius_m,
                )
            )
        except shape.FenceError as exc:
            raise CatalogError(f"fence {fence.name!r}: {exc}", field="fences") from None
    if not wire:
        raise CatalogError(
            f"{vessel.name} has no fences, of its own or every vessel's, to send", field="fences"
        )
    return {"fences": wire}


def fence_send(
    *,
    fence: Fence,
    vessel: Vessel | None = None,
    created_by: str = "",
    source: str = Source.API,
    now: dt.datetime | None = None,
) -> Command:
    """Queue a `fence` command loading ``vessel``'s whole fence set into its autopilot, sent
    from ``fence`` (the admin action or the API names one); ``vessel`` defaults to the
    fence's own. Raises CommandError (or CatalogError) with the reason; audited as
    ``fence.sent`` in the same transaction.

    1. The vessel must be an ArduPilot (MAVLink) boat, and the fence its own or every
       vessel's: another boat's fence is never loaded here.
    2. The set is built (:func:`fence_set_params`) and checked by the catalog as any command
       is (the autopilot's storage, a polygon across 180°), then queued. It is not a
       navigation command: a running move_to or mission goes on.
    """
    vessel = vessel or fence.vessel
    if vessel is None:
        raise CommandError(
            f"fence {fence.name!r} is every vessel's: name the vessel to send it to",
            field="vessel",
        )
    if vessel.kind != MAVLINK:
        raise CommandError(
            f"{vessel.name} is a {vessel.get_kind_display()}; only ArduPilot boats hold a fence",
            field="vessel",
        )
    if fence.vessel_id is not None and fence.vessel_id != vessel.pk:
        raise CommandError(
            f"fence {fence.name!r} belongs to {fence.vessel.name}, not {vessel.name}",
            field="vessel",
        )
    params = fence_set_params(vessel=vessel)
    # One audit entry naming what was sent (command_enqueue's audit_as), not two.
    return command_enqueue(
        vessel=vessel,
        kind="fence",
        params=params,
        source=source,
        created_by=created_by,
        now=now,
        audit_as={
            "action": "fence.sent",
            "subject_type": "fence",
            "subject_id": fence.pk,
            "subject": fence.name,
            "detail": {
                "fences": [f["id"] for f in params["fences"]],
                "items": shape.mavlink_item_count(params["fences"]),
            },
        },
    )
