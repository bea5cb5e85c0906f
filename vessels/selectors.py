from __future__ import annotations

from typing import Any

from django.db.models import QuerySet
from django.shortcuts import get_object_or_404

from vessels import sql
from vessels.models import Fence, Mission, Vessel, VesselKey


def vessel_list() -> QuerySet[Vessel]:
    return Vessel.objects.all().order_by("name")


def fleet_vessels() -> QuerySet[Vessel]:
    """Active vessels for the fleet map, by name: one query, only the columns the map shows."""
    return (
        Vessel.objects.filter(active=True)
        .only(
            "id", "slug", "name", "kind", "telemetry_period_s", "last_seen_at", "last_fix",
        )
        .order_by("name")
    )  # fmt: skip


def vessel_by_slug(slug: str) -> Vessel:
    return get_object_or_404(Vessel, slug=slug)


def vessel_commands_version(vessel_id: int) -> int:
    """The vessel's commands_version as stored now: a vessel from the recent key lookups
    (vessels.auth.key_lookup_recent) may carry one up to a minute old."""
    return sql.commands_version(vessel_id)


def vessel_key_by_hash(key_hash: str) -> VesselKey | None:
    """The key with this hash and its vessel (partly loaded: only what authentication and the
    boat API read), or None. Written out in vessels.sql: the hottest query of the site."""
    return sql.key_by_hash(key_hash)


def key_valid_sql(vendor: str) -> str:
    """SQL true while the key with id %s works: see vessels.sql.key_valid_sql."""
    return sql.key_valid_sql(vendor)


def vessel_key_works(key_id: int) -> bool:
    """Whether the key still works (not revoked, its vessel active)."""
    return sql.key_works(key_id)


def missions_visible_to(user: Any) -> QuerySet[Mission]:
    """The missions ``user`` may see: templates, and missions of vessels they may view.

    A mission names its vessel and traces its route: an operator without the right to see
    vessels sees only the templates."""
    missions = Mission.objects.select_related("vessel").prefetch_related("items")
    if not user.has_perm("vessels.view_vessel"):
        missions = missions.filter(vessel__isnull=True)
    return missions.order_by("name", "pk")


def fences_visible_to(user: Any) -> QuerySet[Fence]:
    """The fences ``user`` may see: those every vessel keeps, and those of vessels they may
    view (as missions_visible_to)."""
    fences = Fence.objects.select_related("vessel")
    if not user.has_perm("vessels.view_vessel"):
        fences = fences.filter(vessel__isnull=True)
    return fences.order_by("name", "pk")
