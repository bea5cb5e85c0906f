"""The two mission checks have one name each: the route's (vessels.services) and everything a
send checks (commands.services: the catalog for the vessel's kind, then the route)."""

from __future__ import annotations

import pytest

from commands.services import mission_send_problems
from vessels.models import Mission, Vessel
from vessels.services import mission_route_problems, mission_write

pytestmark = pytest.mark.django_db

ROUTE = [{"lat": -31.95, "lon": 115.86}, {"lat": -31.96, "lon": 115.87}]


def test_a_route_the_vessel_cannot_run_passes_the_route_check_but_not_the_send_check(
    glider: Vessel,
) -> None:
    mission = mission_write(
        mission=Mission(), fields={"name": "Loop", "vessel": glider}, items=ROUTE
    )
    assert mission_route_problems(mission=mission) == []
    [problem] = mission_send_problems(mission=mission)
    assert problem.startswith("mission is not available for wave_glider vessels")


def test_a_route_problem_is_both_checks_problem(vessel_a: Vessel) -> None:
    same = [ROUTE[0], ROUTE[0]]
    mission = mission_write(
        mission=Mission(), fields={"name": "Loop", "vessel": vessel_a}, items=same
    )
    [problem] = mission_route_problems(mission=mission)
    assert problem.startswith("waypoints 1 and 2 are the same point")
    assert mission_send_problems(mission=mission) == mission_route_problems(mission=mission)
