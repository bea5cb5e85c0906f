"""Commands as the boat receives them from ``GET boat/commands/``: read (:func:`parse_command`)
and their parameters checked against the catalog (:func:`validate`). Pure; split from
``executor.py``, which runs them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from edge_client.contract import fence
from edge_client.contract.catalog import KIND_PARAMS, MISSION_ENDS, MISSION_MAX_ITEMS, RANGES
from edge_client.contract.kinds import ROVER_MODES


class CommandError(ValueError):
    """A command that cannot run; the message is the ack's detail."""


@dataclass(frozen=True)
class Command:
    uid: str
    kind: str
    params: dict[str, Any]
    expires_at: datetime | None = None


def parse_command(raw: Any) -> Command:
    """One entry of ``GET boat/commands/`` → Command (params not yet validated)."""
    if not isinstance(raw, dict) or not isinstance(raw.get("uid"), str) or not raw["uid"]:
        raise CommandError(f"command without a uid: {raw!r}")
    params = raw.get("params") or {}
    if not isinstance(params, dict):
        raise CommandError("params is not an object")
    expires = None
    if raw.get("expires_at"):
        try:
            expires = datetime.fromisoformat(str(raw["expires_at"]).replace("Z", "+00:00"))
        except ValueError:
            expires = None  # the server's business; don't refuse a command over it
    return Command(uid=raw["uid"], kind=str(raw.get("kind", "")), params=params, expires_at=expires)


def _number(value: Any, name: str) -> float:
    """A finite number within the catalog's range for ``name`` (edge_client.contract.catalog)."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise CommandError(f"{name} must be a number, got {value!r}")
    lo, hi = RANGES[name]
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise CommandError(f"{name} {value} is outside {_bound(lo)}…{_bound(hi)}")
    return float(value)


def _bound(limit: float | None) -> str:
    return "" if limit is None else f"{limit:g}"


def _mission_item(item: Any) -> dict[str, Any]:
    if not isinstance(item, dict):
        raise CommandError("is not an object")
    hold, radius, speed = item.get("hold_s"), item.get("radius_m"), item.get("speed_mps")
    return {
        "lat": _number(item.get("lat"), "lat"),
        "lon": _number(item.get("lon"), "lon"),
        "hold_s": 0.0 if hold is None else _number(hold, "hold_s"),
        # No radius: 0 on the wire, which makes the autopilot use its own WP_RADIUS (common.xml
        # MAV_CMD_NAV_WAYPOINT param2).
        "radius_m": 0.0 if radius is None else _number(radius, "radius_m"),
        # No speed: the autopilot keeps the speed it has (no DO_CHANGE_SPEED is sent).
        "speed_mps": None if speed is None else _number(speed, "speed_mps"),
    }


def _mission(params: dict[str, Any]) -> dict[str, Any]:
    items = params.get("items")
    if not isinstance(items, list) or not items:
        raise CommandError("mission has no items")
    if len(items) > MISSION_MAX_ITEMS:
        raise CommandError(f"mission has {len(items)} items, more than {MISSION_MAX_ITEMS}")
    clean = []
    for i, item in enumerate(items):
        try:
            clean.append(_mission_item(item))
        except CommandError as exc:
            raise CommandError(f"item {i}: {exc}") from None
    mission_id = params.get("mission_id")
    if mission_id is not None:
        if not float(_number(mission_id, "mission_id")).is_integer():
            raise CommandError(f"mission_id must be a whole number, got {mission_id!r}")
        mission_id = int(mission_id)
    loop = bool(params.get("loop", False))
    end = params.get("end") or ("loop" if loop else "stop")
    if end not in MISSION_ENDS or (loop and end != "loop"):
        raise CommandError(f"mission end {end!r} is not one of {', '.join(MISSION_ENDS)}")
    return {"items": clean, "loop": end == "loop", "end": end, "mission_id": mission_id}


def validate(kind: str, params: dict[str, Any]) -> dict[str, Any]:
    """Check a command's params (the server validated them too; a boat trusts no one).

    The kinds, ranges, limits and mode names are the contract's (edge_client.contract), which
    the server's catalog is built from.
    """
    if kind not in KIND_PARAMS:
        raise CommandError(f"unknown command kind {kind!r}")
    if kind == "move_to":
        return {"lat": _number(params.get("lat"), "lat"), "lon": _number(params.get("lon"), "lon")}
    if kind == "set_mode":
        mode = params.get("mode")
        if not isinstance(mode, str) or mode.upper() not in ROVER_MODES:
            raise CommandError(f"unknown Rover mode {mode!r} (known: {', '.join(ROVER_MODES)})")
        return {"mode": mode.upper()}
    if kind == "mission":
        return _mission(params)
    if kind == "fence":
        try:
            return {"fences": fence.clean_fences(params.get("fences"), autopilot=True)}
        except fence.FenceError as exc:
            raise CommandError(str(exc)) from None
    return {}
