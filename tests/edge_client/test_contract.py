"""The boat–shore contract (edge_client/contract/): one table each, pinned to ArduPilot's own.

The numbers are spelled in the contract so that it stays pure; pymavlink (which the boat runs)
carries MAVLink's and ArduPilot's definitions, so a typo or a renumbering fails here.
"""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as apm  # noqa: E402

from edge_client import catalog as edge_catalog  # noqa: E402
from edge_client import mission as edge_mission  # noqa: E402
from edge_client.contract.kinds import ROVER_MODE_INITIALISING, ROVER_MODE_NAMES, ROVER_MODES  # noqa: E402
from edge_client.contract.mavcmd import MavCmd  # noqa: E402
from edge_client.contract.status import FINAL, OPEN, UNFINISHED, Status  # noqa: E402


@pytest.mark.parametrize("command", list(MavCmd), ids=lambda c: c.name)
def test_mav_cmd_numbers_are_mavlinks(command: MavCmd) -> None:
    assert getattr(apm, f"MAV_CMD_{command.name}") == command
    assert apm.enums["MAV_CMD"][command].name == f"MAV_CMD_{command.name}"


@pytest.mark.parametrize("name", ROVER_MODES)
def test_rover_modes_are_ardupilots(name: str) -> None:
    assert getattr(apm, f"ROVER_MODE_{name}") == ROVER_MODES[name]


def test_the_boot_mode_is_ardupilots_and_every_number_has_one_name() -> None:
    assert apm.ROVER_MODE_INITIALIZING == ROVER_MODE_INITIALISING
    assert ROVER_MODE_NAMES[ROVER_MODE_INITIALISING] == "INITIALISING"
    assert len(ROVER_MODE_NAMES) == len(ROVER_MODES) + 1


def test_the_status_groups_cover_every_status_once() -> None:
    assert FINAL | UNFINISHED == set(Status) and not FINAL & UNFINISHED
    assert set(OPEN) <= UNFINISHED and Status.ACKNOWLEDGED in UNFINISHED


def test_no_copy_of_the_tables_is_left_on_the_boat() -> None:
    assert not hasattr(edge_catalog, "ROVER_MODES")
    assert edge_mission.MAV_CMD_NAV_WAYPOINT is MavCmd.NAV_WAYPOINT

