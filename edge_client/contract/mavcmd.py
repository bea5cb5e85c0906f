"""The MAV_CMD numbers (MAVLink common.xml) a Shoreside mission or fence is built from and
read back, and the names MAVLink gives any number of its enums (for messages: "MAV_CMD_NAV_LAND").

The numbers are spelled here rather than taken from pymavlink at import time so that this
package stays pure (the server's mission-file code and the boat's mission machine import it
without loading pymavlink's 1 MB dialect); ``tests/edge_client/test_contract.py`` pins every
number to pymavlink's own ``MAV_CMD`` enum, so they cannot drift from it. The names are
pymavlink's, read on first use (:func:`name`): no table of them is kept here.
"""

from __future__ import annotations

import functools
from enum import IntEnum


class MavCmd(IntEnum):
    NAV_WAYPOINT = 16
    NAV_LOITER_TIME = 19
    NAV_RETURN_TO_LAUNCH = 20
    DO_JUMP = 177
    DO_CHANGE_SPEED = 178
    # Geofence items (mission_type FENCE): param1 a polygon's vertex count or a circle's radius.
    NAV_FENCE_POLYGON_VERTEX_INCLUSION = 5001
    NAV_FENCE_POLYGON_VERTEX_EXCLUSION = 5002
    NAV_FENCE_CIRCLE_INCLUSION = 5003
    NAV_FENCE_CIRCLE_EXCLUSION = 5004


def name(enum: str, value: int) -> str | None:
    """MAVLink's name for ``value`` in ``enum`` (``MAV_CMD``, ``MAV_FRAME``,
    ``MAV_MISSION_RESULT``…), as pymavlink's ArduPilot dialect (common.xml and ArduPilot's own)
    spells it; None for a number it does not know."""
    return _names(enum).get(value)


@functools.cache
def _names(enum: str) -> dict[int, str]:
    # Guarded: both the boat's extra and the server's install pymavlink, but this package must
    # import without it (a tool that needs only the tables); then every number is unnamed.
    try:
        import pymavlink.dialects.v20.ardupilotmega as ardupilotmega
    except ImportError:
        return {}
    entries = ardupilotmega.enums.get(enum, {})
    return {n: e.name for n, e in entries.items() if not e.name.endswith("_ENUM_END")}
