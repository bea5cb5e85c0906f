"""Mission rules and figures: the checks a mission passes before it is sent, and its legs,
distances and times at a vessel's cruise speed. Pure (stdlib and vessels.geo only).

Items are mappings with ``lat``, ``lon`` and optional ``hold_s``, ``radius_m``, ``speed_mps``
(the shape of the ``mission`` command's items and of ``Mission.as_params()``).

Speed: a speed change is sent as MAV_CMD_DO_CHANGE_SPEED just before its waypoint
(edge_client/mission.py), and ArduPilot runs a DO command as soon as it sets off toward the
next NAV command; so an item's ``speed_mps`` is the speed of the leg *to* it and of every leg
after, until the next change.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from vessels.geo import bearing_deg, distance_m

# Per-item ranges. The command catalog (commands/catalog.py: HOLD_S, RADIUS_M, SPEED_MPS,
# MISSION_ENDS) takes them from here: vessels sits below commands, so this is their one home.
# ArduPilot Rover keeps a waypoint's hold in 16 bits and reads it signed (Rover mode_auto.cpp
# do_nav_wp: a negative delay is none), so 32,767 s is the longest hold a boat can carry out.
HOLD_MAX_S = 32_767.0
RADIUS_MIN_M, RADIUS_MAX_M = 0.5, 1000.0
SPEED_MIN_MPS, SPEED_MAX_MPS = 0.1, 20.0
ENDS = ("stop", "loop", "return_home")
# A mission item's fields, in the catalog's order (commands/catalog.py MISSION_ITEM_PARAMS).
ITEM_FIELDS = ("lat", "lon", "hold_s", "radius_m", "speed_mps")
# The most items a mission may hold: the catalog sends no more (commands/catalog.py), so a
# longer one is refused where it is saved or imported rather than stored and never sendable.
MISSION_MAX_ITEMS = 500

# The default for settings.MISSION_MAX_LEG_M: a leg longer than this is almost always a
# mistyped coordinate (a sign, a swapped lat/lon), not a plan.
DEFAULT_MAX_LEG_M = 50_000.0
DEFAULT_CRUISE_SPEED_MPS = 1.5

# MISSION_ITEM_INT carries degrees × 1e7: two points equal at that precision are one point
# to the autopilot, which reaches the second at once (or, with a hold, never moves).
_E7 = 1e7


@dataclass(frozen=True)
class Leg:
    """One leg: from item ``start`` to item ``to`` (1-based seq; ``to`` is "home" for the
    return leg), its length, initial bearing, the speed it is sailed at and how long it takes."""

    start: int
    to: int | str
    distance_m: float
    bearing_deg: float
    speed_mps: float
    time_s: float

    def as_dict(self) -> dict[str, Any]:
        fields = asdict(self)
        return {"from": fields.pop("start"), **fields}


@dataclass(frozen=True)
class Summary:
    legs: list[Leg]
    total_m: float
    hold_s: float
    total_s: float  # sailing plus holding, one lap of a loop

    def as_dict(self) -> dict[str, Any]:
        return {
            "legs": [leg.as_dict() for leg in self.legs],
            "total_m": self.total_m,
            "hold_s": self.hold_s,
            "total_s": self.total_s,
        }


def _leg(
    start: int, to: int | str, a: Mapping[str, Any], b: Mapping[str, Any], speed: float
) -> Leg:
    metres = distance_m(a["lat"], a["lon"], b["lat"], b["lon"])
    return Leg(
        start=start,
        to=to,
        distance_m=metres,
        bearing_deg=bearing_deg(a["lat"], a["lon"], b["lat"], b["lon"]),
        speed_mps=speed,
        time_s=metres / speed,
    )


def legs(
    items: Sequence[Mapping[str, Any]],
    *,
    cruise_speed_mps: float = DEFAULT_CRUISE_SPEED_MPS,
    end: str = "stop",
    home: tuple[float, float] | None = None,
) -> list[Leg]:
    """The legs between consecutive items, then last → first for a loop (one lap), or last →
    the planned home for ``return_home`` when a home is known."""
    if cruise_speed_mps <= 0:
        raise ValueError("cruise speed must be above 0")
    out: list[Leg] = []
    speed = cruise_speed_mps
    if items and items[0].get("speed_mps"):
        speed = items[0]["speed_mps"]
    for n in range(1, len(items)):
        speed = items[n].get("speed_mps") or speed
        out.append(_leg(n, n + 1, items[n - 1], items[n], speed))
    if items and end == "loop" and len(items) > 1:
        speed = items[0].get("speed_mps") or speed
        out.append(_leg(len(items), 1, items[-1], items[0], speed))
    elif items and end == "return_home" and home is not None:
        target = {"lat": home[0], "lon": home[1]}
        out.append(_leg(len(items), "home", items[-1], target, speed))
    return out


def summary(
    items: Sequence[Mapping[str, Any]],
    *,
    cruise_speed_mps: float = DEFAULT_CRUISE_SPEED_MPS,
    end: str = "stop",
    home: tuple[float, float] | None = None,
) -> Summary:
    """Legs, total distance and total time (sailing at the set speeds plus every hold)."""
    route = legs(items, cruise_speed_mps=cruise_speed_mps, end=end, home=home)
    holds = float(sum(item.get("hold_s") or 0 for item in items))
    sailing = sum(leg.time_s for leg in route)
    return Summary(
        legs=route,
        total_m=sum(leg.distance_m for leg in route),
        hold_s=holds,
        total_s=sailing + holds,
    )


def problems(
    items: Sequence[Mapping[str, Any]], *, max_leg_m: float, end: str = "stop"
) -> list[str]:
    """Every reason not to send this route, in words an operator can act on; [] when none.

    At least one item; no two consecutive items at the same point; no leg (the loop's
    closing leg included) longer than ``max_leg_m``. The size the autopilot can store is the
    command catalog's rule (``commands.catalog.mission_mavlink_item_count``).
    """
    if not items:
        return ["a mission needs at least one waypoint"]
    found = []
    for n in range(1, len(items)):
        a, b = items[n - 1], items[n]
        if _same_point(a, b):
            found.append(
                f"waypoints {n} and {n + 1} are the same point ({b['lat']:.7f}, {b['lon']:.7f})"
            )
    for leg in legs(items, end=end):
        if leg.distance_m > max_leg_m:
            found.append(
                f"leg {leg.start} → {leg.to} is {format_distance(leg.distance_m)}, longer than "
                f"the limit of {format_distance(max_leg_m)} (MISSION_MAX_LEG_M)"
            )
    return found


def _same_point(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    return round(a["lat"] * _E7) == round(b["lat"] * _E7) and round(a["lon"] * _E7) == round(
        b["lon"] * _E7
    )


def format_distance(metres: float) -> str:
    return f"{metres / 1000:.1f} km" if metres >= 1000 else f"{metres:.0f} m"


def format_duration(seconds: float) -> str:
    minutes = round(seconds / 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min" if hours else f"{minutes} min"
