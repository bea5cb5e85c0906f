"""Upgrading commands: source "system" is now called "vessel" (commands 0003), and back."""

from __future__ import annotations

import pytest
from django.db import connection
from django.db.migrations.executor import MigrationExecutor

BEFORE = [("commands", "0002_command_reported")]
AFTER = [("commands", "0003_command_source_map_vessel")]


def migrate(targets: list[tuple[str, str]]):  # noqa: ANN201 (historical app registry)
    executor = MigrationExecutor(connection)
    executor.loader.build_graph()
    executor.migrate(targets)
    # The vessels app stays at its newest: its models as the database has them.
    vessels = executor.loader.graph.leaf_nodes("vessels")
    return executor.loader.project_state([*targets, *vessels]).apps


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_commands_the_vessel_made_itself_say_vessel_after_the_upgrade() -> None:
    old = migrate(BEFORE)
    vessel = old.get_model("vessels", "Vessel").objects.create(name="G", slug="g")
    Command = old.get_model("commands", "Command")
    for kind, source in (("hold", "system"), ("light", "sms"), ("arm", "api")):
        Command.objects.create(vessel=vessel, kind=kind, source=source)
    new = migrate(AFTER)
    sources = dict(new.get_model("commands", "Command").objects.values_list("kind", "source"))
    assert sources == {"hold": "vessel", "light": "sms", "arm": "api"}
    back = migrate(BEFORE)
    sources = dict(back.get_model("commands", "Command").objects.values_list("kind", "source"))
    assert sources == {"hold": "system", "light": "sms", "arm": "api"}
    # Leave every app fully migrated (apps depending on commands 0002 were rolled back too).
    executor = MigrationExecutor(connection)
    migrate(executor.loader.graph.leaf_nodes())


# (to_status, actor, detail before 0004) → (cc_code, cc_reason, tid, src_task, src_board) after
OLD_PROSE = [
    ("sent", "wg-bridge", "handed over to the C&C in reply to request queued tid 0x01AF from 0/1",
     (None, "", 0x01AF, 0, 1)),
    ("acknowledged", "wg-bridge", "C&C: ACK (accepted)", (0, "", None, None, None)),
    ("failed", "wg-bridge", "C&C: NAK 2: invalid data", (2, "invalid data", None, None, None)),
    ("failed", "wg-bridge", "refused by the inner command table: provisional entry not enabled",
     (None, "provisional entry not enabled", None, None, None)),
    # the sent event of a refused command is no handover
    ("sent", "wg-bridge", "not handed over: refused by the inner command table: x",
     (None, "", None, None, None)),
    ("failed", "wg-bridge", "no answer from the C&C box", (None, "", None, None, None)),
    # a mirror on the shore: not the bridge's
    ("failed", "vessel", "C&C: NAK 3: unable to complete", (None, "", None, None, None)),
]  # fmt: skip


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_the_bridges_old_prose_becomes_the_events_fields_once() -> None:
    """commands 0004: what the Wave Glider bridge wrote as text before (its events' detail) is
    parsed once into the fields it writes now; the detail stays, nobody else's events change."""
    old = migrate(AFTER)
    vessel = old.get_model("vessels", "Vessel").objects.create(name="G", slug="g")
    command = old.get_model("commands", "Command").objects.create(vessel=vessel, kind="fhead")
    Event = old.get_model("commands", "CommandEvent")
    for to_status, actor, detail, _ in OLD_PROSE:
        Event.objects.create(
            command=command, at=command.created_at, to_status=to_status, actor=actor, detail=detail
        )
    new = migrate([("commands", "0004_command_event_cc_fields")])
    rows = (
        new.get_model("commands", "CommandEvent")
        .objects.order_by("pk")
        .values_list(
            "to_status", "actor", "detail", "cc_code", "cc_reason", "tid", "src_task", "src_board"
        )
    )
    assert [(*row[:3], tuple(row[3:])) for row in rows] == OLD_PROSE
    executor = MigrationExecutor(connection)
    migrate(executor.loader.graph.leaf_nodes())
