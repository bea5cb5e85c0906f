"""The commands app's hand-written SQL, each statement beside the reason for it: what the ORM
cannot say, or says in more statements where the count is pinned.

Pinned by tests/commands/test_enqueue_statements.py (and, for an SMS, by
tests/sms/test_services_statements.py).
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence

from django.db import connection

from commands.lifecycle import Status
from commands.models import Command

# First key of the two-key PostgreSQL advisory lock that serialises navigation enqueues.
ENQUEUE_LOCK_SPACE = 0x5353  # "SS", Shoreside


def enqueue_lock(vessel_id: int) -> None:
    """Take the vessel's navigation-enqueue advisory lock until the transaction ends
    (PostgreSQL; a no-op elsewhere).

    Reason: the ORM has no advisory locks. Under READ COMMITTED, two racing navigation
    enqueues each looked for older queued navigation commands before the other had committed,
    and both stayed queued; a row lock on the vessel would invert the lock order of cancel/ack
    (command row, then the vessel's commands_version) and deadlock with them. SQLite needs
    nothing: its IMMEDIATE transactions already run one at a time.
    (tests/commands/test_concurrency.py)
    """
    if connection.vendor != "postgresql":
        return
    with connection.cursor() as cursor:
        cursor.execute(
            "SELECT pg_advisory_xact_lock(%s, %s)", [ENQUEUE_LOCK_SPACE, vessel_id & 0x7FFFFFFF]
        )


def queued_supersede(
    *,
    vessel_id: int,
    kinds: Sequence[str],
    keep: int,
    now: dt.datetime,
    detail: str,
) -> list[int]:
    """Mark the vessel's other queued commands of ``kinds`` (all but ``keep``, and not the
    ones the vessel reported itself) superseded; the ids changed, sorted.

    Reason: one conditional UPDATE … RETURNING (PostgreSQL; SQLite >= 3.35), which the ORM
    cannot write (its update() returns a count), instead of a locking read and an update: one
    statement fewer on every navigation enqueue (pinned), and the WHERE re-checks ``queued``
    row by row (on PostgreSQL after any lock wait), so a command a poll sent or an operator
    cancelled meanwhile is left alone and only the rows it changed get an event.
    """
    table = connection.ops.quote_name(Command._meta.db_table)
    placeholders = ", ".join(["%s"] * len(kinds))
    with connection.cursor() as cursor:
        cursor.execute(
            f"UPDATE {table} SET status = %s, finished_at = %s, result_detail = %s "
            f"WHERE vessel_id = %s AND status = %s AND kind IN ({placeholders}) AND id <> %s "
            # A command the vessel made itself and only reports up is the vessel's to change.
            "AND reported = %s RETURNING id",
            [
                Status.SUPERSEDED.value,
                connection.ops.adapt_datetimefield_value(now),
                detail,
                vessel_id,
                Status.QUEUED.value,
                *kinds,
                keep,
                False,
            ],
        )
        return sorted(row[0] for row in cursor.fetchall())
