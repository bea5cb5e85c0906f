"""A fence's geometry, checked and put in one shape (pure: no ORM, no I/O).

A fence is GeoJSON (RFC 7946), [longitude, latitude] as GeoJSON has it:

- a ``Polygon`` with its outer ring only, closed (the last position repeats the first,
  RFC 7946 §3.1.6), of at least three distinct vertices;
- a ``Point``, the centre of a circle of ``radius_m`` metres (GeoJSON has no circle; QGC
  and ArduPilot do, and so does Leaflet.draw).

Both the map's drawing, the API and the file import (vessels.missionfiles.fences) come here,
so a fence the shore watches is one the autopilot can hold (ArduPilot Rover stores polygon
vertices and circles: MAV_CMD_NAV_FENCE_POLYGON_VERTEX_* and MAV_CMD_NAV_FENCE_CIRCLE_*).
"""

from __future__ import annotations

import math
from typing import Any

from edge_client.contract import fence as shape
from vessels.errors import VesselsError
from vessels.missions import LAT_RANGE, LON_RANGE

# The shape's own rules (vertex counts, a polygon that crosses itself, a circle's size) are
# the contract's, the same the boat checks (edge_client/contract/fence.py); what the boat's
# storage holds is checked when the fence is sent. Here only GeoJSON's own rules are added.
FENCE_MAX_VERTICES = shape.POLYGON_MAX_VERTICES
# A circle of under a metre is a slip of the mouse, not a mooring.
RADIUS_MIN_M = 1.0
RADIUS_MAX_M = shape.RADIUS_MAX_M
COORD_DECIMALS = 7  # ~1 cm, as MAVLink's int32 degE7 carries them


class FenceError(VesselsError):
    """A fence geometry that cannot be stored or sent."""

    field = "geometry"


def _finite(value: Any) -> bool:
    if not isinstance(value, int | float) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # a JSON integer past float's range
        return False


def position(where: str, value: Any) -> tuple[float, float]:
    """A GeoJSON position [lon, lat] (an altitude after them is dropped) as (lon, lat)."""
    if not isinstance(value, list | tuple) or not 2 <= len(value) <= 3:
        raise FenceError(
            f"{where}: a position is [longitude, latitude] or [longitude, latitude, altitude] "
            f"(got {value!r:.60})"
        )
    lon, lat = value[0], value[1]
    if not (_finite(lon) and _finite(lat)):
        raise FenceError(f"{where}: longitude and latitude must be numbers (got {lon!r}, {lat!r})")
    (lat_lo, lat_hi), (lon_lo, lon_hi) = LAT_RANGE, LON_RANGE
    if not (lon_lo <= lon <= lon_hi and lat_lo <= lat <= lat_hi):
        raise FenceError(
            f"{where}: [{lon}, {lat}] is outside {lon_lo:g}…{lon_hi:g} longitude, "
            f"{lat_lo:g}…{lat_hi:g} latitude (GeoJSON puts longitude first)"
        )
    return round(float(lon), COORD_DECIMALS), round(float(lat), COORD_DECIMALS)


def _ring(value: Any) -> list[list[float]]:
    if not isinstance(value, list):
        raise FenceError("a Polygon's coordinates are a list of rings, each a list of positions")
    if len(value) != 1:
        raise FenceError(
            "a fence polygon has one ring, its outline (holes are not supported: draw an "
            "exclusion fence inside it instead)"
            if len(value) > 1
            else "the Polygon has no ring"
        )
    ring = value[0]
    if not isinstance(ring, list):
        raise FenceError("a Polygon's ring is a list of positions")
    points = [position(f"vertex {n}", p) for n, p in enumerate(ring, start=1)]
    if len(points) < 4 or points[0] != points[-1]:
        raise FenceError(
            "the ring must be closed: its last position repeats the first (RFC 7946 §3.1.6)"
        )
    if len(set(points)) < 3:
        raise FenceError("a fence polygon needs at least 3 distinct vertices")
    return [[lon, lat] for lon, lat in points]


def _radius(value: Any) -> float:
    if value is None:
        raise FenceError("a circle (a Point) needs radius_m, its radius in metres")
    if not _finite(value) or not RADIUS_MIN_M <= value <= RADIUS_MAX_M:
        raise FenceError(
            f"radius_m {value!r} is not within {RADIUS_MIN_M:g}…{RADIUS_MAX_M:g} m",
        )
    return float(value)


def clean(geometry: Any, radius_m: Any = None) -> tuple[dict[str, Any], float | None]:
    """The geometry and radius as stored: a closed Polygon ring of rounded [lon, lat], or a
    Point with its radius. Raises FenceError naming what is wrong."""
    if not isinstance(geometry, dict):
        raise FenceError("geometry must be a GeoJSON object: a Polygon, or a Point with radius_m")
    kind = geometry.get("type")
    coordinates = geometry.get("coordinates")
    if kind == "Polygon":
        if radius_m is not None:
            raise FenceError("radius_m is for a circle (a Point), not a Polygon")
        stored, radius = {"type": "Polygon", "coordinates": [_ring(coordinates)]}, None
    elif kind == "Point":
        lon, lat = position("the centre", coordinates)
        stored, radius = {"type": "Point", "coordinates": [lon, lat]}, _radius(radius_m)
    else:
        raise FenceError(f"geometry type must be Polygon or Point (a circle), not {kind!r:.40}")
    try:
        shape.from_geojson(stored, radius)
    except shape.FenceError as exc:
        raise FenceError(str(exc)) from None
    return stored, radius


def vertices(geometry: dict[str, Any]) -> list[tuple[float, float]]:
    """A stored polygon's vertices as (lat, lon), without the closing repeat; [] for a circle."""
    if geometry.get("type") != "Polygon":
        return []
    return [(lat, lon) for lon, lat in geometry["coordinates"][0][:-1]]


def describe(geometry: dict[str, Any], radius_m: float | None) -> str:
    """A fence's shape in words: "polygon, 5 vertices" or "circle, 250 m"."""
    if geometry.get("type") == "Point":
        return f"circle, {radius_m:g} m"
    return f"polygon, {len(vertices(geometry))} vertices"
