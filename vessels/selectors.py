from __future__ import annotations

import datetime as dt
import functools
from typing import Any

from django.db import connection
from django.db.models import QuerySet
from django.shortcuts import get_object_or_404

from vessels.models import Mission, Vessel, VesselKey


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


# The boat API authenticates every request, so this lookup is the hottest query of the site:
# the ORM spent ~1 ms compiling `select_related` for it (profiled, bench.server), several times
# the query itself. The SQL is written once from the models' metadata instead; only these
# columns load, and the rest of each instance is deferred (fetched if ever touched).
_KEY_COLUMNS = ("id", "vessel_id", "revoked_at", "last_used_at")
_VESSEL_COLUMNS = ("id", "slug", "kind", "active", "commands_version")


@functools.cache
def _key_lookup_sql(vendor: str) -> str:
    qn = connection.ops.quote_name
    key, vessel = VesselKey._meta, Vessel._meta
    columns = [f"k.{qn(key.get_field(c).column)}" for c in _KEY_COLUMNS]
    columns += [f"v.{qn(vessel.get_field(c).column)}" for c in _VESSEL_COLUMNS]
    return (
        f"SELECT {', '.join(columns)} FROM {qn(key.db_table)} k "
        f"JOIN {qn(vessel.db_table)} v ON v.{qn(vessel.pk.column)} = k.{qn('vessel_id')} "
        f"WHERE k.{qn(key.get_field('key_hash').column)} = %s"
    )


def _as_datetime(value: Any) -> dt.datetime | None:
    """SQLite returns stored text, PostgreSQL aware datetimes; both become aware UTC."""
    if value is None or isinstance(value, dt.datetime) and value.tzinfo is not None:
        return value
    if isinstance(value, str):
        value = dt.datetime.fromisoformat(value)
    return value.replace(tzinfo=dt.UTC)


def vessel_key_by_hash(key_hash: str) -> VesselKey | None:
    """The key with this hash and its vessel (partly loaded, see above), or None."""
    with connection.cursor() as cursor:
        cursor.execute(_key_lookup_sql(connection.vendor), [key_hash])
        row = cursor.fetchone()
    if row is None:
        return None
    key_id, vessel_id, revoked_at, last_used_at, *vessel_row = row
    vessel = Vessel.from_db(connection.alias, list(_VESSEL_COLUMNS), vessel_row)
    vessel.active = bool(vessel.active)
    key = VesselKey.from_db(
        connection.alias,
        list(_KEY_COLUMNS),
        [key_id, vessel_id, _as_datetime(revoked_at), _as_datetime(last_used_at)],
    )
    key.vessel = vessel
    return key


@functools.cache
def key_valid_sql(vendor: str) -> str:
    """SQL true while the key with id %s works (not revoked, its vessel active): the condition
    a write made on a recently looked-up key (vessels.auth.key_lookup_recent) carries, so a
    revoked key stops at once even though its lookup was not repeated."""
    qn = connection.ops.quote_name
    key, vessel = VesselKey._meta, Vessel._meta
    revoked, active = key.get_field("revoked_at").column, vessel.get_field("active").column
    return (
        f"EXISTS (SELECT 1 FROM {qn(key.db_table)} k JOIN {qn(vessel.db_table)} v"
        f" ON v.{qn(vessel.pk.column)} = k.{qn('vessel_id')}"
        f" WHERE k.{qn(key.pk.column)} = %s AND k.{qn(revoked)} IS NULL AND v.{qn(active)})"
    )


def vessel_key_works(key_id: int) -> bool:
    """Whether the key still works (see key_valid_sql)."""
    with connection.cursor() as cursor:
        cursor.execute(f"SELECT 1 WHERE {key_valid_sql(connection.vendor)}", [key_id])
        return cursor.fetchone() is not None


def missions_visible_to(user: Any) -> QuerySet[Mission]:
    """The missions ``user`` may see: templates, and missions of vessels they may view.

    A mission names its vessel and traces its route: an operator without the right to see
    vessels sees only the templates."""
    missions = Mission.objects.select_related("vessel").prefetch_related("items")
    if not user.has_perm("vessels.view_vessel"):
        missions = missions.filter(vessel__isnull=True)
    return missions.order_by("name", "pk")
