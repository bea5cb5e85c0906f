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
