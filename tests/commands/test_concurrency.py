"""Two polls racing for the same vessel on a real database must never both take the same
command (docs/architecture.md). Runs on SQLite by default and on PostgreSQL with
DATABASE_URL; each thread has its own connection, released through a Barrier so the polls
really overlap."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest
from django.db import connection, connections

from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from commands.services import command_cancel, command_claim_open, command_enqueue
from tests.conftest import boat_client
from vessels.models import Vessel
from vessels.services import vessel_create, vessel_key_issue

POLLERS = 2
ROUNDS = 8
COMMANDS_PER_ROUND = 4


def race(*jobs: Callable[[], Any]) -> list[Any]:
    """Run ``jobs`` in threads started together; return their results (re-raising errors)."""
    barrier = threading.Barrier(len(jobs))
    results: list[Any] = [None] * len(jobs)
    errors: list[BaseException] = []

    def run(i: int, job: Callable[[], Any]) -> None:
        try:
            barrier.wait(timeout=10)
            results[i] = job()
        except BaseException as exc:  # noqa: BLE001 - handed to the main thread
            errors.append(exc)
        finally:
            connections.close_all()  # this thread's own connection

    threads = [threading.Thread(target=run, args=(i, job)) for i, job in enumerate(jobs)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=60)
    assert not any(t.is_alive() for t in threads), "a poller hung"
    if errors:
        raise errors[0]
    return results


@pytest.fixture
def racing_vessel(transactional_db: None) -> Vessel:
    return vessel_create(slug="racer", name="Racer", kind="mavlink")


def sent_events(command: Command) -> int:
    return CommandEvent.objects.filter(command=command, to_status=Status.SENT).count()


def enqueue_round(vessel: Vessel) -> list[Command]:
    # Non-navigation kinds, so none of them supersedes another.
    kinds = ["arm", "disarm"]
    return [
        command_enqueue(vessel=vessel, kind=kinds[i % 2], params={})
        for i in range(COMMANDS_PER_ROUND)
    ]


@pytest.mark.django_db(transaction=True)
def test_racing_polls_send_each_command_exactly_once(racing_vessel: Vessel) -> None:
    for _ in range(ROUNDS):
        commands = enqueue_round(racing_vessel)
        results = race(*[lambda: command_claim_open(vessel=racing_vessel)] * POLLERS)
        # At-least-once: every poller is handed every open command...
        for offered in results:
            assert {c.uid for c in commands} <= {c.uid for c in offered}
            assert all(c.status == Status.SENT for c in offered)
        # ...but each went queued→sent once, with one transition record.
        for command in commands:
            command.refresh_from_db()
            assert command.status == Status.SENT
            assert sent_events(command) == 1
    assert Command.objects.filter(status=Status.QUEUED).count() == 0


@pytest.mark.django_db(transaction=True)
def test_racing_http_polls_send_each_command_exactly_once(racing_vessel: Vessel) -> None:
    keys = [vessel_key_issue(vessel=racing_vessel, label=f"poller {i}")[1] for i in range(2)]
    for _ in range(ROUNDS // 2):
        commands = enqueue_round(racing_vessel)
        responses = race(
            *[lambda key=key: boat_client(key).get("/api/v1/boat/commands/") for key in keys]
        )
        for response in responses:
            assert response.status_code == 200
            offered = {c["uid"] for c in response.json()["commands"]}
            assert {str(c.uid) for c in commands} <= offered
        for command in commands:
            assert sent_events(command) == 1


@pytest.mark.django_db(transaction=True)
def test_a_poll_racing_a_cancel_leaves_one_consistent_history(racing_vessel: Vessel) -> None:
    for _ in range(ROUNDS):
        command = command_enqueue(vessel=racing_vessel, kind="arm", params={})
        copy = Command.objects.get(pk=command.pk)
        race(
            lambda: command_claim_open(vessel=racing_vessel),
            lambda copy=copy: command_cancel(command=copy, actor="alice"),
        )
        command.refresh_from_db()
        # Either order is fine (a sent command may still be cancelled); what matters is one
        # record per transition and a chain that ends at the stored status.
        chain = [(e.from_status, e.to_status) for e in command.events.order_by("at", "pk")]
        assert chain in (
            [("", "queued"), ("queued", "cancelled")],
            [("", "queued"), ("queued", "sent"), ("sent", "cancelled")],
        )
        assert command.status == Status.CANCELLED


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_racing_navigation_commands_leave_only_the_newest_queued(
    racing_vessel: Vessel, monkeypatch: pytest.MonkeyPatch, settings: Any
) -> None:
    settings.MOVE_TO_MAX_M = 0  # about the race, not how far a move_to may go
    # Two operators queue a move_to at once. Under PostgreSQL's READ COMMITTED each enqueue
    # looked for older queued navigation commands before the other had committed, so both
    # stayed queued. The barrier holds each enqueue just before that look: when enqueues
    # are serialised per vessel, the second never gets there while the first waits, the
    # barrier times out and the first goes on alone.
    from commands.services import enqueue

    barrier = threading.Barrier(2)
    real = enqueue._supersede_older_navigation

    def meet_then_supersede(command: Command, now: Any) -> None:
        try:
            barrier.wait(timeout=2)
        except threading.BrokenBarrierError:
            pass
        real(command, now)

    monkeypatch.setattr(enqueue, "_supersede_older_navigation", meet_then_supersede)
    race(
        *[
            lambda lat=lat: command_enqueue(
                vessel=racing_vessel, kind="move_to", params={"lat": lat, "lon": 115.8}
            )
            for lat in (-31.0, -32.0)
        ]
    )
    statuses = sorted(Command.objects.values_list("status", flat=True))
    assert statuses == [Status.QUEUED, Status.SUPERSEDED]


def test_the_suite_is_on_a_database_that_can_race() -> None:
    # An in-memory SQLite database is one per connection: the threads would not share it.
    if connection.vendor == "sqlite":
        name = str(connection.settings_dict["TEST"]["NAME"] or "")
        assert name and ":memory:" not in name and "mode=memory" not in name
