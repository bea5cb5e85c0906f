"""Vessel kinds and ArduPilot Rover's modes, shared by server and boat (docs/architecture.md)."""

from __future__ import annotations

MAVLINK = "mavlink"  # ArduPilot Rover boats such as the SPAB
WAVE_GLIDER = "wave_glider"  # Liquid Robotics Wave Gliders (Level 2 + SMS)

# ArduPilot Rover modes an operator may ask for (ArduPilot Rover/mode.h, `enum Number`). The
# one table: the command catalog offers these, the boat checks set_mode against them, the pages
# and the simulator name the mode_number reading with them.
ROVER_MODES: dict[str, int] = {
    "MANUAL": 0,
    "ACRO": 1,
    "STEERING": 3,
    "HOLD": 4,
    "LOITER": 5,
    "FOLLOW": 6,
    "SIMPLE": 7,
    "DOCK": 8,
    "CIRCLE": 9,
    "AUTO": 10,
    "RTL": 11,
    "SMART_RTL": 12,
    "GUIDED": 15,
}
# Modes whose Mode::requires_position() is true in Rover (mode.h): Rover refuses them until its
# EKF has a position. The boat waits for one before asking; the simulator refuses as Rover does.
ROVER_POSITION_MODES = frozenset(
    {"AUTO", "GUIDED", "LOITER", "FOLLOW", "CIRCLE", "DOCK", "RTL", "SMART_RTL"}
)
# The mode Rover reports while it boots (mode.h `INITIALISING = 16`): never asked for, so not
# in ROVER_MODES, but a fix sent during start-up carries it and the pages name it.
ROVER_MODE_INITIALISING = 16
# Every number Rover may report, named (the simulator's table, the pages' names).
ROVER_MODE_NAMES: dict[int, str] = {
    **{number: name for name, number in ROVER_MODES.items()},
    ROVER_MODE_INITIALISING: "INITIALISING",
}
