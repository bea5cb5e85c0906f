"""The server's catalog is built from the contract's command tables, which the boat checks by.

``edge_client.contract.catalog`` holds the MAVLink kinds, their parameter names, the ranges and
the limits once; ``commands/catalog.py`` takes them from there and the boat validates with them
(``edge_client/commands.py``). These tests hold the server to the contract's objects and the
boat to refusing just outside them, so the boat never refuses a command the server accepted.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from commands import catalog
from edge_client.contract import catalog as contract
from edge_client.contract.kinds import ROVER_MODES
from edge_client.executor import CommandError, validate
from edge_client.mission import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_JUMP,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_WAYPOINT,
    build_mission,
)
from edge_client.sim.rover import MAX_MISSION_ITEMS as SIM_MAX_MISSION_ITEMS
from edge_client.sim.rover import MODES as SIM_MODES
from edge_client.vehicle import MODE_NAMES

ROOT = Path(__file__).resolve().parents[2]
MAVLINK_KINDS = catalog.kinds_for(catalog.MAVLINK)
MISSION_ITEM_PARAMS = catalog.MISSION_ITEM_PARAMS


def ranged(params: tuple[catalog.Param, ...]) -> dict[str, tuple[float | None, float | None]]:
    return {
        p.name: (p.minimum, p.maximum)
        for p in params
        if p.minimum is not None or p.maximum is not None
    }


def test_the_servers_mavlink_kinds_are_the_contracts_with_its_parameters() -> None:
    assert {k.name: tuple(p.name for p in k.params) for k in MAVLINK_KINDS} == (
        contract.KIND_PARAMS
    )
    assert tuple(p.name for p in MISSION_ITEM_PARAMS) == contract.MISSION_ITEM_PARAMS


def test_navigation_kinds_are_the_contracts() -> None:
    assert {k.name for k in MAVLINK_KINDS if k.navigation} == contract.NAVIGATION_KINDS


def test_every_range_of_the_server_is_the_contracts() -> None:
    server: dict[str, tuple[float | None, float | None]] = {}
    for params in [*(kind.params for kind in MAVLINK_KINDS), MISSION_ITEM_PARAMS]:
        for name, bounds in ranged(params).items():
            # The contract keys ranges by parameter name: one name, one range everywhere.
            assert server.setdefault(name, bounds) == bounds, name
    assert server == contract.RANGES


def test_the_servers_ends_and_limits_are_the_contracts_objects() -> None:
    assert catalog.MISSION_ENDS is contract.MISSION_ENDS
    assert catalog.KINDS["mission"].param("end").choices is contract.MISSION_ENDS
    assert catalog.MISSION_MAX_ITEMS == contract.MISSION_MAX_ITEMS
    assert catalog.MISSION_MAX_MAVLINK_ITEMS == contract.MISSION_MAX_MAVLINK_ITEMS


def test_a_kind_whose_parameters_differ_from_the_contracts_is_refused_at_import() -> None:
    with pytest.raises(ValueError, match="contract's parameters"):
        catalog._boat_kind("move_to", "Move to a point", catalog.LAT)


# The contract's distinctive numbers (a position's limits, the longest hold, the mission
# limits): spelling one again in these modules is the copy the contract replaced. (0.5, 1000
# and the like are left out: they also round times and format distances.)
CONTRACT_NUMBERS = {90, 180, 32767, 500, 724}
READ_FROM_THE_CONTRACT = [
    "commands/catalog.py",
    "vessels/missions.py",
    "edge_client/commands.py",
    "edge_client/sim/mission.py",
    "edge_client/mission.py",
    "vessels/models.py",
    "vessels/missionfiles/model.py",
    "telemetry/models.py",
    "telemetry/parsing.py",
    "sms/language.py",
]


@pytest.mark.parametrize("module", READ_FROM_THE_CONTRACT)
def test_no_module_spells_the_contracts_numbers_again(module: str) -> None:
    tree = ast.parse((ROOT / module).read_text())
    numbers = {
        node.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and type(node.value) in (int, float)
    }
    assert numbers & CONTRACT_NUMBERS == set()


def test_the_simulated_rover_holds_as_many_mission_items_as_the_catalog_allows_for() -> None:
    assert SIM_MAX_MISSION_ITEMS == contract.MISSION_MAX_MAVLINK_ITEMS


def test_rover_modes_are_the_catalogs_by_name_and_number() -> None:
    assert catalog.KINDS["set_mode"].param("mode").choices == tuple(ROVER_MODES)
    # The HEARTBEAT decoder knows them all, plus the boot-time mode nobody may ask for.
    assert MODE_NAMES == {n: name for name, n in ROVER_MODES.items()} | {16: "INITIALISING"}
    assert "INITIALISING" not in ROVER_MODES


def test_the_simulated_rover_knows_every_catalog_mode_by_the_same_number() -> None:
    assert SIM_MODES == ROVER_MODES | {"INITIALISING": 16}


@pytest.mark.parametrize("name", sorted(contract.RANGES))
def test_the_boat_refuses_just_outside_each_catalog_range_and_takes_its_ends(name: str) -> None:
    lo, hi = contract.RANGES[name]

    def check(value: float) -> dict:
        if name in ("lat", "lon"):
            return validate("move_to", {"lat": 0, "lon": 0, name: value})
        if name == "mission_id":
            return validate("mission", {"items": [{"lat": 0, "lon": 0}], "mission_id": value})
        return validate("mission", {"items": [{"lat": 0, "lon": 0, name: value}]})

    for end in (lo, hi):
        if end is not None:
            check(end)
    for outside in (lo - 0.25 if lo is not None else None, hi + 0.25 if hi is not None else None):
        if outside is not None:
            with pytest.raises(CommandError, match=name):
                check(outside)


def test_a_mission_one_item_past_the_catalogs_limit_is_refused() -> None:
    items = [{"lat": 0, "lon": 0}] * catalog.MISSION_MAX_ITEMS
    assert len(validate("mission", {"items": items})["items"]) == catalog.MISSION_MAX_ITEMS
    with pytest.raises(CommandError, match=f"more than {catalog.MISSION_MAX_ITEMS}"):
        validate("mission", {"items": [*items, {"lat": 0, "lon": 0}]})


@pytest.mark.parametrize("mode", catalog.ROVER_MODES)
def test_every_catalog_mode_is_accepted_by_the_boat(mode: str) -> None:
    assert validate("set_mode", {"mode": mode.lower()}) == {"mode": mode}


def test_the_boot_time_mode_cannot_be_asked_for() -> None:
    with pytest.raises(CommandError, match="unknown Rover mode"):
        validate("set_mode", {"mode": "INITIALISING"})


MISSION_ITEMS = st.lists(
    st.fixed_dictionaries(
        {
            "lat": st.floats(-90, 90),
            "lon": st.floats(-180, 180),
            "hold_s": st.floats(0, 3600),
            "radius_m": st.none() | st.floats(0.5, 1000),
            "speed_mps": st.none() | st.floats(0.1, 20),
        }
    ),
    min_size=1,
    max_size=40,
)


@settings(max_examples=150, deadline=None)
@given(items=MISSION_ITEMS, end=st.sampled_from(catalog.MISSION_ENDS))
def test_the_boat_uploads_exactly_the_items_the_catalog_counts_in_the_documented_order(
    items: list[dict], end: str
) -> None:
    # Every item the catalog cleans, the boat builds; the count is the server's.
    clean = catalog.validate("mission", {"items": items, "end": end}, vessel_kind=catalog.MAVLINK)
    mission = build_mission((-31.98, 115.82), validate("mission", clean.params)["items"], end=end)
    assert len(mission) == catalog.mission_mavlink_item_count(clean.params["items"], end)
    # Home, then per item [DO_CHANGE_SPEED if it has a speed] + NAV_WAYPOINT, then the end.
    expected = [MAV_CMD_NAV_WAYPOINT]
    for item in items:
        expected += [MAV_CMD_DO_CHANGE_SPEED] * (item["speed_mps"] is not None)
        expected.append(MAV_CMD_NAV_WAYPOINT)
    expected += {"stop": [], "loop": [MAV_CMD_DO_JUMP], "return_home": [
        MAV_CMD_NAV_RETURN_TO_LAUNCH]}[end]  # fmt: skip
    assert [i.command for i in mission] == expected
    assert [i.seq for i in mission] == list(range(len(mission)))
    waypoints = [i for i in mission[1:] if i.command == MAV_CMD_NAV_WAYPOINT]
    speeds = [i.param2 for i in mission if i.command == MAV_CMD_DO_CHANGE_SPEED]
    assert [(w.x, w.y) for w in waypoints] == [
        (round(i["lat"] * 1e7), round(i["lon"] * 1e7)) for i in items
    ]
    assert [w.param2 for w in waypoints] == [i["radius_m"] or 0.0 for i in items]
    assert speeds == [i["speed_mps"] for i in items if i["speed_mps"] is not None]
