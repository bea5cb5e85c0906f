"""The boat's copy of the command rules of the server's catalog (``commands/catalog.py``).

The server validates every command through its catalog before a boat sees it; the boat checks
again because it trusts no one (a bug, an old server, a hand-written request). The edge client
runs on the Pi without Django or the server's apps, so it cannot import the catalog: it keeps
this copy instead, and ``tests/edge_client/test_catalog_contract.py`` pins every kind, parameter
name, range, limit and mode name here to the catalog, so the two cannot drift apart.
"""

from __future__ import annotations

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
}
# Kinds that give the boat a new navigation goal, replacing whatever it was doing.
NAVIGATION_KINDS = frozenset({"move_to", "hold", "resume", "return_home", "set_mode", "mission"})
MISSION_ITEM_PARAMS: tuple[str, ...] = ("lat", "lon", "hold_s", "radius_m", "speed_mps")
# How a mission may end (catalog MISSION_ENDS).
MISSION_ENDS: tuple[str, ...] = ("stop", "loop", "return_home")

# (minimum, maximum) of every ranged parameter, of a command or of a mission item; None = open.
RANGES: dict[str, tuple[float | None, float | None]] = {
    "lat": (-90, 90),
    "lon": (-180, 180),
    "hold_s": (0, 32767),
    "radius_m": (0.5, 1000),
    "speed_mps": (0.1, 20),
    "mission_id": (1, None),
}
MISSION_MAX_ITEMS = 500
# Rover's mode names are not copied here: both sides take them from edge_client.contract.kinds.
