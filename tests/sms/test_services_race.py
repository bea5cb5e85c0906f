"""Two deliveries of one SMS racing (a modem re-read while the first is still being stored):
real transactions on a real database, in two threads.

The race is made to happen, not hoped for: the first delivery stores its message and holds its
transaction open; the second runs, watched statement by statement (:class:`Watch`), and the
first commits only once the second has reached the point where the first's open transaction
is in its way. Each test then checks that the second really ran into the first (a clash on the
unique index, or a wait on SQLite's write lock) and did not simply come after it.
"""

from __future__ import annotations

import datetime as dt
import threading
from collections.abc import Callable
from typing import Any

import pytest
from django.db import IntegrityError, connection, transaction

from commands.models import Command
from sms.models import SmsMessage
from sms.services import authorised_number_authorise, sms_handle_incoming
from tests.support import BASE
from vessels.models import Vessel

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]
WAIT_S = 10  # only ever reached when something is broken


class Watch:
    """An execute wrapper on the second delivery's connection: notes each statement it starts
    (and whether the first delivery had committed by then) and the ones that clashed, and sets
    ``reached`` when a statement ``in_the_way`` starts (given the statement, its parameters and
    the statements before it)."""

    def __init__(self, committed: threading.Event, in_the_way: Callable[[str, Any, list], bool]):
        self.committed, self.in_the_way = committed, in_the_way
        self.reached = threading.Event()
        self.started: list[tuple[str, bool]] = []  # (statement, first committed before it)
        self.clashed: list[str] = []

    def __call__(self, execute: Callable, sql: str, params: Any, many: bool, context: Any) -> Any:
        if self.in_the_way(sql, params, self.started):
            self.reached.set()  # before it runs: it may wait on the first's transaction
        self.started.append((sql, self.committed.is_set()))
        try:
            return execute(sql, params, many, context)
        except IntegrityError:
            self.clashed.append(sql)
            raise


def race(first: Callable[[], object], second: Callable[[], object], watch: Watch) -> dict:
    """Run ``first`` in a transaction held open until ``second`` (watched) is in its way."""
    stored, results = threading.Event(), {}

    def run_first() -> None:
        try:
            with transaction.atomic():
                results["first"] = first()
                stored.set()  # stored, not committed yet
                watch.reached.wait(WAIT_S)
            watch.committed.set()
        finally:
            connection.close()

    def run_second() -> None:
        try:
            with connection.execute_wrapper(watch):
                results["second"] = second()
        finally:
            connection.close()

    threads = [threading.Thread(target=run_first), threading.Thread(target=run_second)]
    threads[0].start()
    assert stored.wait(WAIT_S)
    threads[1].start()
    for thread in threads:
        thread.join(2 * WAIT_S)
    assert watch.reached.is_set(), "the second delivery never reached the first's transaction"
    return results


def is_twin_check(sql: str) -> bool:
    """The look for an earlier delivery of the same SMS (sms.services.incoming._delivered):
    a SELECT whose WHERE is on the delivery key (every SELECT of the table names the column)."""
    where = sql.partition(" WHERE ")[2]
    return sql.startswith("SELECT") and where.startswith('"sms_smsmessage"."delivery_key" =')


def test_a_delivery_racing_its_twin_is_handled_once(glider: Vessel) -> None:
    authorised_number_authorise(number="+61412345678", vessels=[glider], role="control", name="S")

    def handle() -> object:
        return sms_handle_incoming(
            vessel=glider, number="+61412345678", text="#FHEAD 230",
            received_at=BASE, modem_timestamp=BASE,
        )  # fmt: skip

    # In the way: whatever the second does once its look for a twin found none (SQLite: its
    # BEGIN IMMEDIATE waits for the write lock; PostgreSQL: its work up to the INSERT).
    watch = Watch(
        threading.Event(), lambda sql, params, before: any(is_twin_check(s) for s, _ in before)
    )
    results = race(handle, handle, watch)

    checks = [committed for sql, committed in watch.started if is_twin_check(sql)]
    assert checks[0] is False  # the second looked for its twin before the first committed …
    assert [sql.split()[:3] for sql in watch.clashed] == [["INSERT", "INTO", '"sms_smsmessage"']]
    assert not results["first"].duplicate  # … ran into it on the unique index, and said so:
    assert results["second"].duplicate
    assert results["second"].message.pk == results["first"].message.pk
    assert results["second"].reply_texts == ["#FHEAD 230 QUEUED"]
    assert Command.objects.count() == 1
    assert SmsMessage.objects.count() == 2


def test_two_texts_over_the_limit_at_once_give_one_notice(glider: Vessel, settings: object) -> None:
    settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S = 1, 600  # type: ignore[attr-defined]
    authorised_number_authorise(number="+61412345678", vessels=[glider], role="control", name="S")
    sms_handle_incoming(
        vessel=glider, number="+61412345678", text="#STATUS", received_at=BASE
    )  # the one answered: the block runs to 08:10

    def handle(seconds: int) -> object:
        when = BASE + dt.timedelta(seconds=seconds)
        return sms_handle_incoming(
            vessel=glider, number="+61412345678", text=f"#LIGHT {seconds}",
            received_at=when, modem_timestamp=when,
        )  # fmt: skip

    def notice_insert(sql: str, params: Any, before: list) -> bool:
        return sql.startswith("INSERT") and any(str(p).startswith("rate:") for p in params or ())

    # In the way, PostgreSQL: the second's own notice INSERT (it waits on the first's index
    # entry). SQLite lets one writer in at a time: the second's BEGIN IMMEDIATE waits instead.
    sqlite = connection.vendor == "sqlite"
    watch = Watch(
        threading.Event(),
        (lambda sql, params, before: sql.startswith("BEGIN")) if sqlite else notice_insert,
    )
    results = race(lambda: handle(10), lambda: handle(11), watch)

    if sqlite:
        begins = [committed for sql, committed in watch.started if sql.startswith("BEGIN")]
        assert begins[0] is False  # the second asked for the write lock while the first held it
        assert watch.clashed == []  # and, let in after the commit, saw the notice sent
    else:
        assert [sql.split()[:2] for sql in watch.clashed] == [["INSERT", "INTO"]]
    assert [results[n].outcome for n in ("first", "second")] == ["rate_limited"] * 2
    assert len(results["first"].replies) == 1
    assert results["second"].replies == ()
    notices = SmsMessage.objects.filter(direction="out", text__startswith="SMS limit")
    assert notices.count() == 1
