"""Upgrading missions: `loop` becomes `end` (vessels 0002), and back."""

from __future__ import annotations

import pytest
from django.db import connection
from django.db.migrations.executor import MigrationExecutor

BEFORE = [("vessels", "0001_initial")]
AFTER = [("vessels", "0002_mission_end_home_speeds")]


def migrate(targets: list[tuple[str, str]]):  # noqa: ANN201 (historical app registry)
    executor = MigrationExecutor(connection)
    executor.loader.build_graph()
    executor.migrate(targets)
    return executor.loader.project_state(targets).apps


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_looping_missions_keep_looping_after_the_upgrade() -> None:
    old = migrate(BEFORE)
    Mission = old.get_model("vessels", "Mission")
    Mission.objects.create(name="round", loop=True)
    Mission.objects.create(name="once", loop=False)
    new = migrate(AFTER)
    ends = dict(new.get_model("vessels", "Mission").objects.values_list("name", "end"))
    assert ends == {"round": "loop", "once": "stop"}
    back = migrate(BEFORE)
    loops = dict(back.get_model("vessels", "Mission").objects.values_list("name", "loop"))
    assert loops == {"round": True, "once": False}
    # Leave every app fully migrated (an app depending on vessels 0002 was rolled back too).
    executor = MigrationExecutor(connection)
    migrate(executor.loader.graph.leaf_nodes())
