"""Mission rules and figures: the checks a mission passes before it is sent, and its legs,
distances and times at a vessel's cruise speed. Pure (stdlib and the contract only).

Items are mappings with ``lat``, ``lon`` and optional ``hold_s``, ``radius_m``, ``speed_mps``
(the shape of the ``mission`` command's items and of ``Mission.as_params()``).

Speed: a speed change is sent as MAV_CMD_DO_CHANGE_SPEED just before its waypoint
(edge_client/mission.py), and ArduPilot runs a DO command as soon as it sets off toward the
next NAV command; so an item's ``speed_mps`` is the speed of the leg *to* it and of every leg
after, until the next change.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

from edge_client.contract import catalog
from edge_client.contract.geo import bearing_deg, distance_m

# Per-item ranges, the ways a mission ends, its fields and its length limit: the contract's
# (edge_client.contract.catalog), which the command catalog and the boat check against too;
# named here for the mission code, forms and files of this app.
LAT_RANGE, LON_RANGE = catalog.RANGES["lat"], catalog.RANGES["lon"]
HOLD_MAX_S = catalog.HOLD_MAX_S
RADIUS_MIN_M, RADIUS_MAX_M = catalog.RANGES["radius_m"]
SPEED_MIN_MPS, SPEED_MAX_MPS = catalog.RANGES["speed_mps"]
ENDS = catalog.MISSION_ENDS
ITEM_FIELDS = catalog.MISSION_ITEM_PARAMS
# The catalog sends no more, so a longer mission is refused where it is saved or imported
# rather than stored and never sendable.
MISSION_MAX_ITEMS = catalog.MISSION_MAX_ITEMS

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
        problem = leg_problem(leg, max_leg_m=max_leg_m)
        if problem:
            found.append(problem)
    return found


def leg_problem(leg: Leg, *, max_leg_m: float) -> str | None:
    """Why this leg stops a send (too long: usually a mistyped coordinate), or None."""
    if leg.distance_m <= max_leg_m:
        return None
    return (
        f"leg {leg.start} → {leg.to} is {format_distance(leg.distance_m)}, longer than "
        f"the limit of {format_distance(max_leg_m)} (MISSION_MAX_LEG_M)"
    )


def item_problems(item: Mapping[str, Any]) -> list[str]:
    """What is wrong with one waypoint on its own (the model's ranges), [] when nothing: the
    planner marks such a row and leaves it off the route rather than draw it anywhere."""
    found = []
    lat, lon = item.get("lat"), item.get("lon")
    for what, value, (lo, hi) in (("latitude", lat, LAT_RANGE), ("longitude", lon, LON_RANGE)):
        if not _number(value) or not lo <= value <= hi:
            found.append(f"{what} {value} is not within {lo:g}…{hi:g}")
    hold = item.get("hold_s") or 0
    if not _number(hold) or not 0 <= hold <= HOLD_MAX_S:
        found.append(f"hold {hold} s is not within 0…{HOLD_MAX_S:g} s")
    radius = item.get("radius_m")
    if radius is not None and (not _number(radius) or not RADIUS_MIN_M <= radius <= RADIUS_MAX_M):
        found.append(f"radius {radius} m is not within {RADIUS_MIN_M:g}…{RADIUS_MAX_M:g} m")
    speed = item.get("speed_mps")
    if speed is not None and (not _number(speed) or not SPEED_MIN_MPS <= speed <= SPEED_MAX_MPS):
        found.append(f"speed {speed} m/s is not within {SPEED_MIN_MPS:g}…{SPEED_MAX_MPS:g} m/s")
    return found


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def review(
    rows: Sequence[Mapping[str, Any]],
    *,
    cruise_speed_mps: float = DEFAULT_CRUISE_SPEED_MPS,
    end: str = "stop",
    home: tuple[float, float] | None = None,
    max_leg_m: float = DEFAULT_MAX_LEG_M,
) -> dict[str, Any]:
    """The one set of figures and checks every mission display shows (the planner, live, and
    the route table), JSON-ready: each row's own problems; the legs over the good rows (a
    row with a problem is left out, as it could not be sent), each with its problem or None;
    the totals and the words they are shown in; and every problem a send would report."""
    good = [row for row in rows if not item_problems(row)]
    plan = summary(good, cruise_speed_mps=cruise_speed_mps, end=end, home=home)
    row_problems = [item_problems(row) for row in rows]
    leg_dicts = []
    for leg in plan.legs:
        leg_dicts.append(
            {
                **leg.as_dict(),
                "distance": format_distance(leg.distance_m),
                "time": format_duration(leg.time_s),
                "problem": leg_problem(leg, max_leg_m=max_leg_m),
            }
        )
    route_problems = problems(good, max_leg_m=max_leg_m, end=end)
    for n, found in enumerate(row_problems, start=1):
        route_problems += [f"row {n}: {problem}" for problem in found]
    return {
        "rows": row_problems,
        "holds": [
            format_duration(row["hold_s"]) if _number(row.get("hold_s")) and row["hold_s"] else ""
            for row in rows
        ],
        "legs": leg_dicts,
        "waypoints": len(good),
        "total_m": plan.total_m,
        "hold_s": plan.hold_s,
        "total_s": plan.total_s,
        "total": totals_text(plan, waypoints=len(good), end=end),
        "problems": route_problems,
    }


END_WORDS = {
    "stop": "then it stops at the last waypoint",
    "loop": "then it loops back to waypoint 1, for ever",
    "return_home": "then it returns home",
}


def send_confirmation(
    review: Mapping[str, Any],
    *,
    items: Sequence[Mapping[str, Any]],
    end: str,
    vessel_name: str,
    last_fix: tuple[float, float] | None,
) -> str:
    """What an operator confirms before a send: the waypoints, distance and time (the
    review's totals), how far the vessel's last fix is from waypoint 1, and the end."""
    if not items:
        where = "it has no waypoints"
    elif last_fix is None:
        where = f"{vessel_name} has no position yet"
    else:
        gap = distance_m(last_fix[0], last_fix[1], items[0]["lat"], items[0]["lon"])
        where = f"{vessel_name}'s last fix is {format_distance(gap)} from waypoint 1"
    return f"Send to {vessel_name}: {review['total']}. {where}; {END_WORDS.get(end, end)}."


def totals_text(plan: Summary, *, waypoints: int, end: str) -> str:
    """The mission's totals in words, e.g. "5 waypoints · 3.2 km · 13 min (holds 30 s)"."""
    text = f"{waypoints} waypoint{'' if waypoints == 1 else 's'} · {format_distance(plan.total_m)}"
    text += f" · {format_duration(plan.total_s)}" + (" per lap" if end == "loop" else "")
    if plan.hold_s:
        text += f" (holds {format_duration(plan.hold_s)})"
    return text


def mismatch(items: Sequence[Mapping[str, Any]], end: str, *, shown: Any) -> str | None:
    """How the route an operator confirmed on screen (``shown``: ``{"end", "items"}``, items
    as ``items`` are) differs from the saved one, in words; None when they are the same route
    (positions equal at MAVLink's 1e-7°, the other fields equal). A send compares them so
    that what is queued is what the operator saw."""
    if not isinstance(shown, Mapping) or not isinstance(shown.get("items"), list):
        return "the route on screen was not confirmed"
    seen = shown["items"]
    if len(seen) != len(items):
        return f"{len(seen)} waypoints on screen, {len(items)} saved"
    for n, (a, b) in enumerate(zip(items, seen, strict=True), start=1):
        if not isinstance(b, Mapping) or not _same_item(a, b):
            return f"waypoint {n} on screen is not waypoint {n} as saved"
    if shown.get("end") != end:
        return f"the end on screen is {shown.get('end')}, saved {end}"
    return None


def saved_since(saved_at: dt.datetime, seen: dt.datetime | None) -> str | None:
    """Why a send must not go out: the mission was saved (its route, its vessel) after the
    version the caller read (``seen``), or None when it was not, or nothing was named. The
    API's send and the mission page's Send both ask, so what goes out is what was seen."""
    if seen is None or seen == saved_at:
        return None
    return (
        f"not sent: the mission was saved at {saved_at.isoformat()}, after the version you "
        "read; read it again and send"
    )


def _same_item(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    try:
        if not _same_point(a, b):
            return False
    except (KeyError, TypeError, ValueError, OverflowError):
        # Not a route a page could show (a missing field, a string, an infinite or NaN
        # coordinate): not the saved one, never a 500.
        return False
    return all(
        (a.get(name) or 0) == (b.get(name) or 0) for name in ("hold_s", "radius_m", "speed_mps")
    )


def _same_point(a: Mapping[str, Any], b: Mapping[str, Any]) -> bool:
    return round(a["lat"] * _E7) == round(b["lat"] * _E7) and round(a["lon"] * _E7) == round(
        b["lon"] * _E7
    )


def format_distance(metres: float) -> str:
    return f"{metres / 1000:.1f} km" if metres >= 1000 else f"{metres:.0f} m"


def format_duration(seconds: float) -> str:
    """Whole minutes (hours past the hour), or seconds under a minute: a 30 s hold is "30 s",
    not "0 min"."""
    whole = math.floor(seconds + 0.5)  # half up, as a person rounds (round() is to even)
    if whole < 60:
        return f"{whole} s"
    minutes = math.floor(seconds / 60 + 0.5)
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min" if hours else f"{minutes} min"
