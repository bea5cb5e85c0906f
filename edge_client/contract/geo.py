"""Distances, bearings and offsets on the Earth, for the server, the boat and its simulator.

A sphere of the mean Earth radius (IUGG, 6,371 km) is good to well under a metre at the few
kilometres a boat covers between two fixes; nothing here needs an ellipsoid. The map pages do
the same sums in JavaScript (``vessels/static/vessels/mapkit.js``, the one copy, since a page
cannot import this); ``tests/browser/test_fleet_map.py`` holds it to these on ~500 pairs.
"""

from __future__ import annotations

import math

EARTH_RADIUS_M = 6_371_000.0


def distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance in metres (haversine)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians(lon2 - lon1)
    a = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_M * math.asin(math.sqrt(min(1.0, a)))  # min: rounding past 1


def bearing_deg(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Initial great-circle bearing from the first point to the second, degrees true [0, 360)."""
    p1, p2, dl = math.radians(lat1), math.radians(lat2), math.radians(lon2 - lon1)
    y = math.sin(dl) * math.cos(p2)
    x = math.cos(p1) * math.sin(p2) - math.sin(p1) * math.cos(p2) * math.cos(dl)
    return math.degrees(math.atan2(y, x)) % 360


def offset(lat: float, lon: float, bearing: float, metres: float) -> tuple[float, float]:
    """The point ``metres`` from (lat, lon) along ``bearing`` (flat-earth; fine below ~10 km)."""
    b = math.radians(bearing)
    dlat = math.degrees(metres * math.cos(b) / EARTH_RADIUS_M)
    dlon = math.degrees(metres * math.sin(b) / (EARTH_RADIUS_M * math.cos(math.radians(lat))))
    return lat + dlat, lon + dlon
