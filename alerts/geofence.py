"""Fence geometry for the fence rules: a fence as the boat and shore agree on it, and whether a
point is inside it.

STAND-IN, to be replaced at merge: the shared fence contract is edge_client/contract/fence.py
(on the fence branch: ``contains(fence, lat, lon)`` and ``wire_fence(id=, name=, inclusion=,
geometry=, radius_m=)``, the same wire shape). The evaluator imports only ``fence_wire`` and
``contains`` from here, so at merge this module becomes::

    from edge_client.contract.fence import contains, wire_fence

    def fence_wire(fence):
        return wire_fence(id=fence.pk, name=fence.name, inclusion=fence.inclusion,
                          geometry=fence.geometry, radius_m=fence.radius_m)

Wire shape (stand-in): {"inclusion": bool, "polygon": [[lat, lon], ...]} (outer ring, not
closed) or {"inclusion": bool, "circle": {"lat", "lon", "radius_m"}}.
"""

from __future__ import annotations

from typing import Any

from edge_client.contract.geo import distance_m


def fence_wire(fence: Any) -> dict[str, Any]:
    """A vessels.Fence (GeoJSON, [lon, lat]) as the wire dict ([lat, lon])."""
    geometry = fence.geometry or {}
    if geometry.get("type") == "Point":
        lon, lat = geometry["coordinates"][:2]
        circle = {"lat": lat, "lon": lon, "radius_m": fence.radius_m or 0.0}
        return {"inclusion": fence.inclusion, "circle": circle}
    ring = [[lat, lon] for lon, lat, *_ in geometry["coordinates"][0]]
    if len(ring) > 1 and ring[0] == ring[-1]:
        ring.pop()
    return {"inclusion": fence.inclusion, "polygon": ring}


def contains(fence: dict[str, Any], lat: float, lon: float) -> bool:
    """Is (lat, lon) inside the fence's area (its inclusion flag aside)?"""
    circle = fence.get("circle")
    if circle:
        return distance_m(lat, lon, circle["lat"], circle["lon"]) <= circle["radius_m"]
    return _in_polygon(fence["polygon"], lat, lon)


def _in_polygon(ring: list[list[float]], lat: float, lon: float) -> bool:
    """Even-odd ray casting on unwrapped longitudes: each vertex is taken within 180 degrees of
    the one before it, and the point within 180 degrees of the ring's middle, so a polygon
    across the antimeridian (179.9 … -179.9) is one small shape, not one spanning the globe."""
    lons = [ring[0][1]]
    for _, x in ring[1:]:
        lons.append(lons[-1] + _wrap(x - lons[-1]))
    middle = (min(lons) + max(lons)) / 2
    lon = middle + _wrap(lon - middle)
    inside = False
    n = len(ring)
    for i in range(n):
        lat1, lon1 = ring[i][0], lons[i]
        lat2, lon2 = ring[(i + 1) % n][0], lons[(i + 1) % n]
        if (lat1 > lat) != (lat2 > lat):
            x = lon1 + (lat - lat1) * (lon2 - lon1) / (lat2 - lat1)
            if x > lon:
                inside = not inside
    return inside


def _wrap(d: float) -> float:
    """A longitude difference in [-180, 180)."""
    return (d + 180.0) % 360.0 - 180.0
