"""MAVLink mission items ↔ a Shoreside mission: the rules the `.plan` and `.waypoints` formats
share (both are lists of MISSION_ITEM fields: command, frame, param1..7). Pure.

Read (common.xml, MAV_CMD): NAV_WAYPOINT (param1 hold s, param2 acceptance radius m) and
NAV_LOITER_TIME (param1 hold s) are waypoints; DO_CHANGE_SPEED (param2 m/s) is the speed of the
next waypoint on; NAV_RETURN_TO_LAUNCH as the last item ends by returning home; DO_JUMP as the
last item, back to the first item, repeating for ever (-1), is a loop. Anything else is
unsupported, named by its number and MAV_CMD name. Write: the reverse, as the edge client
uploads it (edge_client/mission.py): DO_CHANGE_SPEED before its NAV_WAYPOINT, then DO_JUMP to 1
or NAV_RETURN_TO_LAUNCH.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from edge_client.contract import mavcmd
from edge_client.contract.mavcmd import MavCmd
from vessels.errors import MissionFileError
from vessels.missionfiles.model import (
    Item,
    MissionFile,
    finish,
    hold,
    position,
    radius,
    speed,
)

NAN = math.nan

# The boat builds missions from the same numbers (edge_client.contract.mavcmd).
NAV_WAYPOINT = MavCmd.NAV_WAYPOINT
NAV_LOITER_TIME = MavCmd.NAV_LOITER_TIME
NAV_RETURN_TO_LAUNCH = MavCmd.NAV_RETURN_TO_LAUNCH
DO_JUMP = MavCmd.DO_JUMP
DO_CHANGE_SPEED = MavCmd.DO_CHANGE_SPEED

# Commands a boat cannot carry out, by MAVLink's name (mavcmd.name), for the reason given.
_FOR_AIRCRAFT = frozenset(
    f"MAV_CMD_{n}"
    for n in (
        "NAV_LAND",
        "NAV_TAKEOFF",
        "NAV_LOITER_TO_ALT",
        "NAV_VTOL_TAKEOFF",
        "NAV_VTOL_LAND",
        "CONDITION_CHANGE_ALT",
        "DO_LAND_START",
        "DO_VTOL_TRANSITION",
    )
)
_CAMERA = frozenset(
    f"MAV_CMD_{n}"
    for n in (
        "DO_CONTROL_VIDEO",
        "DO_SET_ROI",
        "DO_DIGICAM_CONFIGURE",
        "DO_DIGICAM_CONTROL",
        "DO_MOUNT_CONFIGURE",
        "DO_MOUNT_CONTROL",
        "DO_SET_CAM_TRIGG_DIST",
        "DO_SET_CAM_TRIGG_INTERVAL",
        "SET_CAMERA_MODE",
        "IMAGE_START_CAPTURE",
        "IMAGE_STOP_CAPTURE",
        "VIDEO_START_CAPTURE",
        "VIDEO_STOP_CAPTURE",
    )
)

# MAV_FRAME: positions a boat can sail to are global latitude/longitude (the altitude is
# ignored at the surface); DO commands carry no position and are written in MAV_FRAME_MISSION.
FRAME_GLOBAL = 0
FRAME_MISSION = 2
FRAME_GLOBAL_RELATIVE_ALT = 3
NAV_FRAMES = {FRAME_GLOBAL, FRAME_GLOBAL_RELATIVE_ALT, 5, 6}  # 5, 6: the deprecated *_INT
_TERRAIN_FRAMES = {10, 11}

# ArduPilot DO_JUMP: a repeat count of -1 repeats for ever (edge_client/mission.JUMP_FOREVER).
JUMP_FOREVER = -1
# DO_CHANGE_SPEED param1 speed type (1 = ground speed), param3 throttle (-1 = no change).
SPEED_TYPE_GROUND = 1
THROTTLE_NO_CHANGE = -1


def command_name(command: int) -> str:
    """MAVLink's name for a MAV_CMD number (pymavlink's), or "MAV_CMD <n>" for one it lacks."""
    return mavcmd.name("MAV_CMD", command) or f"MAV_CMD {command}"


def frame_name(frame: int) -> str:
    return mavcmd.name("MAV_FRAME", frame) or f"MAV_FRAME {frame}"


@dataclass(frozen=True)
class RawItem:
    """One item of a file: its number as the file counts it, a MAV_CMD (None for something
    that is not one, such as a QGC ComplexItem, described by ``what``), frame and params."""

    number: int
    command: int | None
    frame: int = FRAME_MISSION
    params: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    jump_id: int | None = None
    what: str = ""

    @property
    def label(self) -> str:
        if self.command is None:
            return f"item {self.number} ({self.what})"
        return f"item {self.number} ({command_name(self.command)})"


def _why_unsupported(command: int) -> str:
    name = mavcmd.name("MAV_CMD", command)
    if name in _FOR_AIRCRAFT:
        return "takeoff, landing and altitude commands are for aircraft"
    if name in _CAMERA:
        return "camera and gimbal actions are not part of a Shoreside mission"
    return "a Shoreside mission holds waypoints, holds, speed changes, a loop or a return home"


def read(
    rows: Sequence[RawItem],
    *,
    skip_unsupported: bool,
    home: tuple[float, float] | None = None,
    name: str = "",
) -> MissionFile:
    """The mission these items describe. Raises MissionFileError listing every invalid item
    and, unless ``skip_unsupported``, every unsupported one; skipped ones are listed."""
    items: list[Item] = []
    unsupported: list[str] = []
    errors: list[str] = []
    end = "stop"
    pending: tuple[float, RawItem] | None = None  # a speed change waiting for its waypoint
    for i, row in enumerate(rows):
        last = i == len(rows) - 1
        where, p = row.label, row.params
        try:
            if row.command is None:
                unsupported.append(f"{where}: a Shoreside mission holds simple items only")
            elif row.command in (NAV_WAYPOINT, NAV_LOITER_TIME):
                if row.frame not in NAV_FRAMES:
                    unsupported.append(f"{where}: {_frame_problem(row.frame)}")
                    continue
                lat, lon = position(where, p[4], p[5])
                accept = radius(where, p[1]) if row.command == NAV_WAYPOINT else None
                change = pending[0] if pending else None
                items.append(Item(lat, lon, hold(where, p[0]), accept, change))
                pending = None
            elif row.command == DO_CHANGE_SPEED:
                if pending is not None:
                    unsupported.append(
                        f"{pending[1].label}: overridden by {where} before a waypoint"
                    )
                pending = (speed(where, p[1]), row)
            elif row.command == NAV_RETURN_TO_LAUNCH:
                if last:
                    end = "return_home"
                else:
                    unsupported.append(f"{where}: a return home is supported only as the last item")
            elif row.command == DO_JUMP:
                problem = _jump_problem(row, first=rows[0], last=last)
                if problem:
                    unsupported.append(f"{where}: {problem}")
                else:
                    end = "loop"
            else:
                unsupported.append(f"{where}: {_why_unsupported(row.command)}")
        except MissionFileError as exc:
            errors.extend(exc.problems)
    if pending is not None:
        unsupported.append(f"{pending[1].label}: a speed change after the last waypoint")
    return finish(
        items,
        end=end,
        home=home,
        name=name,
        errors=errors,
        unsupported=unsupported,
        skip_unsupported=skip_unsupported,
    )


def _frame_problem(frame: int) -> str:
    if frame in _TERRAIN_FRAMES:
        return f"altitude above terrain ({frame_name(frame)}) means nothing to a boat"
    return f"{frame_name(frame)} is not a latitude/longitude frame a boat can use"


def _jump_problem(row: RawItem, *, first: RawItem, last: bool) -> str:
    target, repeat = row.params[0], row.params[1]
    if not last:
        return "a jump is supported only as the last item, back to the first (a loop)"
    if first.jump_id is None or target != first.jump_id:
        return (
            f"a jump to item {_number(target)} (only a jump back to the first item, a loop, "
            "is supported)"
        )
    if repeat != JUMP_FOREVER:
        return f"repeats {_number(repeat)} times (only for ever, -1, is supported)"
    return ""


def _number(value: float) -> str:
    return str(int(value)) if math.isfinite(value) and value.is_integer() else str(value)


def write(mission: MissionFile) -> list[RawItem]:
    """The mission as MAVLink items, numbered from 1, as the boat uploads them."""
    rows: list[RawItem] = []

    def add(command: int, frame: int, params: tuple[float, ...]) -> None:
        n = len(rows) + 1
        rows.append(RawItem(n, command, frame, params, jump_id=n))

    for item in mission.items:
        if item.speed_mps is not None:
            add(
                DO_CHANGE_SPEED,
                FRAME_MISSION,
                (SPEED_TYPE_GROUND, item.speed_mps, THROTTLE_NO_CHANGE, 0, 0, 0, 0),
            )
        # param4 (yaw) NaN: keep the heading the autopilot chooses.
        add(
            NAV_WAYPOINT,
            FRAME_GLOBAL_RELATIVE_ALT,
            (item.hold_s, item.radius_m or 0.0, 0.0, NAN, item.lat, item.lon, 0.0),
        )
    if mission.end == "loop":
        add(DO_JUMP, FRAME_MISSION, (1, JUMP_FOREVER, 0, 0, 0, 0, 0))
    elif mission.end == "return_home":
        add(NAV_RETURN_TO_LAUNCH, FRAME_MISSION, (0, 0, 0, 0, 0, 0, 0))
    return rows
