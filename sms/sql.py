"""The SMS app's hand-written SQL: each statement beside the measurement that justifies it.

Everything else in the app goes through the ORM. The SMS handling path itself has none: its
reads were written out to chase 500 SMS/s, a target withdrawn (a GSM modem takes seconds per
SMS), and went back to the ORM (issue 17).
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.db import connection

from commands.lifecycle import OPEN, Status
from commands.models import Command

# The partial index of open commands (commands.models.Command.Meta.indexes).
OPEN_INDEX = "command_open_by_vessel"


# -- The glider bridge's queued commands (sms.bridge.commands.DatabaseCommandSource) ----------
#
# Benchmark: bench/bridge.py (20,000 finished commands). Every status request of the C&C
# (~1/s) counts the vessel's queued commands. The ORM's COUNT took ~12 ms on SQLite, which
# walked the vessel's whole history through the plain vessel_id index: it cannot match a
# partial index's condition to bound parameters, and without ANALYZE statistics it does not
# prefer it even with literals. Written out, with the index's condition as literals and, on
# SQLite, INDEXED BY: ~0.1 ms. Should the index be gone, SQLite raises OperationalError ("no
# such index" / "no query solution"), and the caller falls back to the ORM.


def waiting_sql(columns: str, tail: str = "") -> str:
    """SELECT ``columns`` over a vessel's queued, unexpired commands through OPEN_INDEX;
    parameters: the vessel's id, ``"queued"`` and now (adapted for the database)."""
    qn = connection.ops.quote_name
    hint = f" INDEXED BY {qn(OPEN_INDEX)}" if connection.vendor == "sqlite" else ""
    # Literals, not parameters, so that SQLite can see the index's own condition (our own
    # enum values: nothing from outside goes into the text).
    open_statuses = ", ".join(f"'{status.value}'" for status in OPEN)
    status = qn("status")
    expires = qn("expires_at")
    return (
        f"SELECT {columns} FROM {qn(Command._meta.db_table)}{hint}"
        f" WHERE {qn('vessel_id')} = %s AND {status} IN ({open_statuses}) AND {status} = %s"
        f" AND ({expires} IS NULL OR {expires} > %s){tail}"
    )


def _first(columns: str, tail: str, vessel_id: int, now: dt.datetime) -> Any:
    params = [vessel_id, Status.QUEUED.value, connection.ops.adapt_datetimefield_value(now)]
    with connection.cursor() as cursor:
        cursor.execute(waiting_sql(columns, tail), params)
        row = cursor.fetchone()
    return None if row is None else row[0]


def queued_count(vessel_id: int, now: dt.datetime) -> int:
    """How many of the vessel's commands are queued and unexpired at ``now``."""
    return int(_first("COUNT(*)", "", vessel_id, now))


def queued_oldest_id(vessel_id: int, now: dt.datetime) -> int | None:
    """The id of the vessel's oldest queued, unexpired command (None: there is none)."""
    qn = connection.ops.quote_name
    found = _first(qn("id"), f" ORDER BY {qn('created_at')}, {qn('id')} LIMIT 1", vessel_id, now)
    return None if found is None else int(found)
