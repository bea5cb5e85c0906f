"""QGroundControl `.plan` files (JSON), read and written. Pure.

Format: docs/missions.md#files (QGC dev guide, file_formats/plan). Items are
numbered from 1 as QGC numbers them (its planned home is 0); DO_JUMP targets a doJumpId.
"""

from __future__ import annotations

import json
import math
from typing import Any

from vessels.errors import MissionFileError
from vessels.missionfiles import mavitems
from vessels.missionfiles.model import (
    MissionFile,
    checked_text,
    finite,
    is_number,
    known_home,
    load_json,
    position,
)

CONTENT_TYPE = "application/json"
EXTENSION = "plan"
GROUND_STATION = "Shoreside"
PLAN_VERSION = 1
MISSION_VERSION = 2
FIRMWARE_ARDUPILOT = 3  # MAV_AUTOPILOT_ARDUPILOTMEGA
VEHICLE_SURFACE_BOAT = 11  # MAV_TYPE_SURFACE_BOAT
# QGC AltitudeMode 1 = relative to launch: a boat's altitude is 0 whatever the mode.
ALTITUDE_RELATIVE = 1


def load(content: bytes | str, *, skip_unsupported: bool = False, name: str = "") -> MissionFile:
    plan = load_json(content, "QGroundControl plan")
    if not isinstance(plan, dict) or plan.get("fileType") != "Plan":
        raise MissionFileError('not a QGroundControl plan: no "fileType": "Plan"')
    mission = plan.get("mission")
    if not isinstance(mission, dict) or not isinstance(mission.get("items"), list):
        raise MissionFileError('not a QGroundControl plan: no "mission" with "items"')
    home = _home(mission.get("plannedHomePosition"))
    rows = [_raw_item(n, item) for n, item in enumerate(mission["items"], start=1)]
    return mavitems.read(rows, skip_unsupported=skip_unsupported, home=home, name=name)


def _home(value: Any) -> tuple[float, float] | None:
    if value is None:
        return None
    if not isinstance(value, list) or len(value) < 2:
        raise MissionFileError("plannedHomePosition must be [latitude, longitude, altitude]")
    return known_home(*position("plannedHomePosition", value[0], value[1]))


def _raw_item(number: int, item: Any) -> mavitems.RawItem:
    where = f"item {number}"
    if not isinstance(item, dict):
        raise MissionFileError(f"{where} is not an object")
    kind = item.get("type")
    if kind != "SimpleItem":
        complex_type = item.get("complexItemType", "?")
        if isinstance(complex_type, str):  # kept in the skipped list and the mission's notes
            complex_type = checked_text(f"{where}: complexItemType", complex_type)
        what = (
            f"ComplexItem {complex_type}"
            if kind == "ComplexItem"
            else (f"an item of type {kind!r}")
        )
        return mavitems.RawItem(number, None, what=what)
    command, frame = item.get("command"), item.get("frame", mavitems.FRAME_GLOBAL)
    if not _whole(command) or not _whole(frame):
        raise MissionFileError(f"{where}: command and frame must be whole numbers")
    params = item.get("params")
    if not isinstance(params, list) or len(params) != 7:
        raise MissionFileError(f"{where}: params must be a list of 7 values")
    if not all(p is None or is_number(p) for p in params):
        raise MissionFileError(f"{where}: params must be numbers or null")
    jump_id = item.get("doJumpId")
    return mavitems.RawItem(
        number,
        int(command),
        int(frame),
        tuple(math.nan if p is None else _float(p) for p in params),
        jump_id=int(jump_id) if _whole(jump_id) else None,
    )


def _whole(value: Any) -> bool:
    return finite(value) and float(value).is_integer()


def _float(value: int | float) -> float:
    try:
        return float(value)
    except OverflowError:  # a huge JSON integer: out of every range, checked later
        return math.inf


def dump(mission: MissionFile, *, cruise_speed_mps: float) -> str:
    home = mission.home or (0.0, 0.0)
    items = [_item_json(row) for row in mavitems.write(mission)]
    plan = {
        "fileType": "Plan",
        "version": PLAN_VERSION,
        "groundStation": GROUND_STATION,
        "mission": {
            "version": MISSION_VERSION,
            "firmwareType": FIRMWARE_ARDUPILOT,
            "vehicleType": VEHICLE_SURFACE_BOAT,
            "globalPlanAltitudeMode": ALTITUDE_RELATIVE,
            "cruiseSpeed": cruise_speed_mps,
            "hoverSpeed": cruise_speed_mps,
            "plannedHomePosition": [home[0], home[1], 0],
            "items": items,
        },
        "geoFence": {"version": 2, "circles": [], "polygons": []},
        "rallyPoints": {"version": 2, "points": []},
    }
    return json.dumps(plan, indent=4, allow_nan=False) + "\n"


def _item_json(row: mavitems.RawItem) -> dict[str, Any]:
    item: dict[str, Any] = {
        "type": "SimpleItem",
        "autoContinue": True,
        "command": row.command,
        "doJumpId": row.jump_id,
        "frame": row.frame,
        "params": [None if math.isnan(p) else p for p in row.params],
    }
    if row.frame != mavitems.FRAME_MISSION:  # a position: QGC's own altitude fields
        item.update(AMSLAltAboveTerrain=None, Altitude=0, AltitudeMode=ALTITUDE_RELATIVE)
    return item
