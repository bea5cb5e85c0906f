"""The MAV_CMD numbers (MAVLink common.xml) a Shoreside mission is built from and read back.

Spelled here rather than taken from pymavlink at import time so that this package stays pure
(the server's mission-file code and the boat's mission machine import it without loading
pymavlink's 1 MB dialect); ``tests/edge_client/test_contract.py`` pins every number to
pymavlink's own ``MAV_CMD`` enum, so they cannot drift from it.
"""

from __future__ import annotations

from enum import IntEnum


class MavCmd(IntEnum):
    NAV_WAYPOINT = 16
    NAV_LOITER_TIME = 19
    NAV_RETURN_TO_LAUNCH = 20
    DO_JUMP = 177
    DO_CHANGE_SPEED = 178
