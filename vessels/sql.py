"""The vessels app's hand-written SQL, each statement beside the reason for it and the benchmark
that measures it: the boat API's key lookup and the vessel's last-fix update.

Benchmark: bench.server (the boat API: polls and single-fix posts, against a naive DRF view);
the statements of a single post are pinned by tests/telemetry/test_boat_api.py, and each
statement here is tested on every database by tests/vessels/test_sql.py.
"""

from __future__ import annotations

import datetime as dt
import functools
from typing import Any

from django.db import connection

from vessels.models import Vessel, VesselKey

# -- The boat API's key lookup (vessels.selectors.vessel_key_by_hash) ---------------------------
#
# Every boat request authenticates, so this is the hottest query of the site: the ORM spent
# ~1 ms compiling `select_related` for it (profiled), several times the query itself. The SQL
# is written once from the models' metadata instead; only these columns load, and the rest of
# each instance is deferred (fetched if ever touched).
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


def key_by_hash(key_hash: str) -> VesselKey | None:
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


# -- The vessel's last fix (vessels.services.vessel_record_fix; telemetry's ingest) -------------
#
# One conditional UPDATE, written once: backlogs arrive oldest first and out of order, so
# "newer" is decided in the database, under the row lock, not in Python. The ORM version cost
# more than the fix insert itself on a single-fix post (profiled).


@functools.cache
def _record_fix_sql(vendor: str, also_if: str = "") -> str:
    meta, qn = Vessel._meta, connection.ops.quote_name
    seen, fix, fix_at = (
        qn(meta.get_field(n).column) for n in ("last_seen_at", "last_fix", "last_fix_at")
    )
    newer = f"({fix_at} IS NULL OR {fix_at} < %s)"
    if also_if:
        newer = f"({newer} AND {also_if})"
    return (
        f"UPDATE {qn(meta.db_table)} SET {seen} = %s, "
        f"{fix} = CASE WHEN {newer} THEN %s ELSE {fix} END, "
        f"{fix_at} = CASE WHEN {newer} THEN %s ELSE {fix_at} END "
        f"WHERE {qn(meta.pk.column)} = %s"
    )


def record_fix(
    *, vessel_id: int, seen_at: dt.datetime, fix_at: dt.datetime, summary: dict[str, Any] | None
) -> None:
    """Mark the vessel seen at ``seen_at``; make ``summary`` its last fix if ``fix_at`` is
    newer than the one it has."""
    sql, params = record_fix_statement(
        vessel_id=vessel_id, seen_at=seen_at, fix_at=fix_at, summary=summary
    )
    with connection.cursor() as cursor:
        cursor.execute(sql, params)


def record_fix_statement(
    *,
    vessel_id: int,
    seen_at: dt.datetime,
    fix_at: dt.datetime,
    summary: dict[str, Any] | None,
    also_if: str = "",
) -> tuple[str, list[Any]]:
    """:func:`record_fix` as (sql, params), for a caller that runs it as part of one
    statement of its own (ingest on PostgreSQL: fixes and vessel in one round trip).
    ``also_if``, a parameterless SQL condition, must hold too for the fix to be taken."""
    # The backend's adapters, straight (both fields are plain: no encoder, aware UTC times):
    # the field layer around them cost a tenth of a single-fix post (profiled, bench.server).
    ops = connection.ops
    at = ops.adapt_datetimefield_value(fix_at)
    summary_value = ops.adapt_json_value(summary, None)
    params = [ops.adapt_datetimefield_value(seen_at), at, summary_value, at, at, vessel_id]
    return _record_fix_sql(connection.vendor, also_if), params
