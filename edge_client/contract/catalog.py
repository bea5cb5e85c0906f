"""The command rules the boat and the server share (docs/edge-client.md#commands): the kinds
a MAVLink boat runs, their parameter names, the ranges, how a mission may end and how long it
may be.

The server's catalog (``commands/catalog.py``) builds its parameters from these tables and
validates every command before a boat sees it; the boat checks again with the same tables
(``edge_client/commands.py``) because it trusts no one (a bug, an old server, a hand-written
request). One table, so the boat never refuses what the server accepted.
"""

from __future__ import annotations

from edge_client.contract import fix

# Command kinds a MAVLink boat runs, each with its parameter names in the catalog's order.
KIND_PARAMS: dict[str, tuple[str, ...]] = {
    "move_to": ("lat", "lon"),
    "hold": (),
    "resume": (),
    "return_home": (),
    "set_mode": ("mode",),
    "arm": (),
    "disarm": (),
    "mission": ("mission_id", "items", "loop", "end"),
    # The whole fence set the autopilot is to hold (edge_client.contract.fence): not a
    # navigation kind, so it replaces no move_to or mission, here or on the boat.
    "fence": ("fences",),
}
# Kinds that give the boat a new navigation goal, replacing whatever it was doing.
NAVIGATION_KINDS = frozenset({"move_to", "hold", "resume", "return_home", "set_mode", "mission"})
# A mission item's fields, in order (the ``items`` of a ``mission`` command, Mission.as_params()).
MISSION_ITEM_PARAMS: tuple[str, ...] = ("lat", "lon", "hold_s", "radius_m", "speed_mps")
# How a mission ends: the boat stops at the last item, starts again from the first, or returns
# home (ArduPilot: nothing, a DO_JUMP to item 1, a final NAV_RETURN_TO_LAUNCH).
MISSION_ENDS: tuple[str, ...] = ("stop", "loop", "return_home")

# ArduPilot Rover keeps a waypoint's hold in 16 bits and reads it signed (Rover mode_auto.cpp
# do_nav_wp: a negative delay is none), so 32,767 s is the longest hold a boat can carry out.
HOLD_MAX_S = 32_767.0
# (minimum, maximum) of every ranged parameter, of a command or of a mission item, both
# inclusive; None = open. A position's are a fix's: one latitude, one longitude everywhere.
RANGES: dict[str, tuple[float | None, float | None]] = {
    "lat": fix.RANGES["lat"],
    "lon": fix.RANGES["lon"],
    "hold_s": (0.0, HOLD_MAX_S),
    "radius_m": (0.5, 1000.0),
    "speed_mps": (0.1, 20.0),
    "mission_id": (1, None),
}
# The most items a mission may hold: the server sends no more, and refuses a longer one where
# it is saved or imported rather than storing one that could never be sent.
MISSION_MAX_ITEMS = 500
# ArduPilot keeps a mission in its storage area; on common boards (16 KiB) that holds 724 items
# (AP_Mission: storage size / 15-byte packed items, less the header). Item 0 is home. The
# server refuses a mission that needs more; the simulated Rover stores no more.
MISSION_MAX_MAVLINK_ITEMS = 724
