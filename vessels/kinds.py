"""Vessel kinds (DESIGN §3). Pure: the models, the command catalog and the edge side share them."""

from __future__ import annotations

MAVLINK = "mavlink"  # ArduPilot Rover boats such as the SPAB
WAVE_GLIDER = "wave_glider"  # Liquid Robotics Wave Gliders (Level 2 + SMS)

# ArduPilot Rover flight modes (ArduPilot Rover/mode.h, `enum Number`); INITIALISING is not
# a mode an operator can ask for. The one table: the command catalog takes it from here (as
# ROVER_MODES), and the pages name the mode_number reading with it (vessels/display.py).
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
# The mode Rover reports while it boots (mode.h `INITIALISING = 16`): never asked for, so not
# in the catalog's table, but a fix sent during start-up carries it and the pages name it.
ROVER_MODE_INITIALISING = 16
