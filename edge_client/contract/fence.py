"""Fences, one shape and one geometry for the shore and the autopilot (docs/alerts.md#fences).

A fence is an area a boat must stay inside (inclusion) or outside (exclusion): a polygon or a
circle. The shore watches it (the alerts' fence rules call :func:`contains` and
:func:`breached`); the ``fence`` command loads the same set into an ArduPilot boat's autopilot
(``edge_client.fence_upload``), which enforces it itself. The wire shape, the command's params::

    {"fences": [{"id": 3, "name": "Harbour", "inclusion": true,
                 "polygon": [[lat, lon], [lat, lon], [lat, lon], ...]},
                {"id": 4, "name": "Wreck", "inclusion": false,
                 "circle": {"lat": -32.0, "lon": 115.7, "radius_m": 150.0}}]}

Polygon vertices are [lat, lon] (as a MAVLink fence item carries them), the ring open (the
first vertex is not repeated at the end). The server stores GeoJSON ([lon, lat], closed ring;
:func:`from_geojson` converts).

The rules are ArduPilot's (libraries/AC_Fence/AC_PolyFence_loader.cpp ``breached``):

- a polygon edge is a straight line in latitude/longitude, as ArduPilot's point-in-polygon
  test (AP_Math ``Polygon_outside``) draws it; a circle is every point within ``radius_m``;
- several inclusion fences are an *intersection*: the boat must be inside every one of them
  (FENCE_OPTIONS bit 1 "union" unset, ArduPilot's default); any exclusion fence is a breach.

The shore's geometry is right across the 180° meridian (an edge takes the short way round);
ArduPilot's is not (it subtracts raw longitudes), so :func:`clean_fences` refuses a polygon
that crosses it when the set is for an autopilot. Pure and stdlib-only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from edge_client.contract.fix import RANGES
from edge_client.contract.geo import EARTH_RADIUS_M, distance_m

# ArduPilot Rover keeps its fences in the StorageFence areas of its storage: 160 + 256 + 256
# bytes on a board with 16 KiB or more (libraries/StorageManager/StorageManager.cpp, the
# "fixed wing and rovers" layout). AC_PolyFence_loader::max_items() is that over 8 (84 items,
# "84 items on PixHawk"): an upload of more is refused MAV_MISSION_NO_SPACE, and write_fence
# refuses a set whose bytes (fence_storage_space_required) do not fit: "Fence exceeds storage
# size". A board with BRD_SD_FENCE set keeps more on its SD card; Shoreside assumes it has not.
FENCE_STORAGE_BYTES = 672
FENCE_MAX_ITEMS = FENCE_STORAGE_BYTES // 8
# Storage bytes (AC_PolyFence_loader::fence_storage_space_required and write_eos_to_storage):
# a 4-byte header, per polygon a type and a count byte and 8 bytes a vertex, per circle a type
# byte and 12 bytes (lat, lon, radius), and the end-of-storage marker.
HEADER_BYTES, END_BYTES, POLYGON_BYTES, VERTEX_BYTES, CIRCLE_BYTES = 4, 1, 2, 8, 13
POLYGON_MIN_VERTICES = 3  # AC_PolyFence_loader::validate_fence: "Invalid vertex count"
POLYGON_MAX_VERTICES = 255  # the vertex count is one byte in storage (uint8_t vertex_count)
# No autopilot limit (a float32 > 0); past this a circle is no fence for a boat, and a typo.
RADIUS_MAX_M = 1_000_000.0
NAME_MAX = 100  # vessels.Fence.name
SHAPES = ("polygon", "circle")


class FenceError(ValueError):
    """A fence that cannot be used as it is; the message says which one and why."""


# -- validation -------------------------------------------------------------------------------


def _number(value: Any, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FenceError(f"{name} must be a number (got {value!r})")
    try:
        number = float(value)
    except OverflowError:
        raise FenceError(f"{name} must be a number (got one out of range)") from None
    if not math.isfinite(number):
        raise FenceError(f"{name} must be a finite number")
    return number


def _coordinate(value: Any, name: str) -> float:
    number = _number(value, name)
    lo, hi = RANGES[name.rsplit(" ", 1)[-1]]
    if not lo <= number <= hi:
        raise FenceError(f"{name} must be between {lo} and {hi} (got {number:g})")
    return number


def e7(degrees: float) -> int:
    """Degrees as ArduPilot keeps them: whole 1e-7 degrees (MISSION_ITEM_INT x, y)."""
    return int(round(degrees * 1e7))


def _wrap(delta: float) -> float:
    """A longitude difference brought into [-180, 180)."""
    return (delta + 180.0) % 360.0 - 180.0


def unwrapped(polygon: Sequence[Sequence[float]]) -> list[tuple[float, float]]:
    """The vertices as (lat, lon) with each edge taking the short way round in longitude:
    the longitudes may leave [-180, 180] (a polygon across the 180° meridian) but no edge
    jumps by more than 180°."""
    points = [(float(polygon[0][0]), float(polygon[0][1]))]
    for lat, lon in polygon[1:]:
        points.append((float(lat), points[-1][1] + _wrap(float(lon) - points[-1][1])))
    return points


def crosses_antimeridian(polygon: Sequence[Sequence[float]]) -> bool:
    """Whether a polygon's short-way edges cross the 180° meridian."""
    return any(not -180.0 <= lon <= 180.0 for _, lon in unwrapped(polygon))


def _orient(a: tuple[int, int], b: tuple[int, int], c: tuple[int, int]) -> int:
    cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    return (cross > 0) - (cross < 0)


def _on_segment(a: tuple[int, int], b: tuple[int, int], p: tuple[int, int]) -> bool:
    return min(a[0], b[0]) <= p[0] <= max(a[0], b[0]) and min(a[1], b[1]) <= p[1] <= max(a[1], b[1])


def _touch(a: tuple[int, int], b: tuple[int, int], c: tuple[int, int], d: tuple[int, int]) -> bool:
    """Whether segments ab and cd share any point (exact: integer coordinates)."""
    o1, o2, o3, o4 = _orient(a, b, c), _orient(a, b, d), _orient(c, d, a), _orient(c, d, b)
    if o1 != o2 and o3 != o4 and 0 not in (o1, o2, o3, o4):
        return True
    return (
        (o1 == 0 and _on_segment(a, b, c))
        or (o2 == 0 and _on_segment(a, b, d))
        or (o3 == 0 and _on_segment(c, d, a))
        or (o4 == 0 and _on_segment(c, d, b))
    )


def _folds(p: tuple[int, int], q: tuple[int, int], r: tuple[int, int]) -> bool:
    """Whether the edges p→q and q→r run back along each other (a spike of no width)."""
    back = (p[0] - q[0]) * (r[0] - q[0]) + (p[1] - q[1]) * (r[1] - q[1])
    return _orient(p, q, r) == 0 and back > 0


def _simple(points: list[tuple[int, int]]) -> str:
    """Why a ring (integer lat/lon, open) is not a simple polygon, or "" when it is.

    O(n²) over at most 255 vertices (32,000 pairs): cheap enough for every save and send.
    """
    n = len(points)
    for k in range(n):
        if _folds(points[k - 1], points[k], points[(k + 1) % n]):
            return f"folds back on itself at vertex {k + 1}"
    edges = [(points[i], points[(i + 1) % n]) for i in range(n)]
    # Each edge's bounding box: most pairs are told apart by it, without the exact test.
    boxes = [(min(a[0], b[0]), max(a[0], b[0]), min(a[1], b[1]), max(a[1], b[1])) for a, b in edges]
    for i in range(n):
        lat0, lat1, lon0, lon1 = boxes[i]
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # neighbours: they share a vertex (folds are checked above)
            box = boxes[j]
            if box[0] > lat1 or box[1] < lat0 or box[2] > lon1 or box[3] < lon0:
                continue
            if _touch(*edges[i], *edges[j]):
                return f"crosses itself (edge {i + 1}-{i + 2} meets edge {j + 1}-{(j + 1) % n + 1})"
    area2 = sum(
        points[i][1] * points[(i + 1) % n][0] - points[(i + 1) % n][1] * points[i][0]
        for i in range(n)
    )
    if area2 == 0:
        return "has no area (its vertices are in a line)"
    return ""


def _polygon(value: Any, *, autopilot: bool) -> list[list[float]]:
    if not isinstance(value, list | tuple):
        raise FenceError("polygon must be a list of [lat, lon] vertices")
    vertices = []
    for i, vertex in enumerate(value):
        if not isinstance(vertex, list | tuple) or len(vertex) != 2:
            raise FenceError(f"vertex {i + 1} must be [lat, lon] (got {vertex!r})")
        vertices.append(
            [
                _coordinate(vertex[0], f"vertex {i + 1} lat"),
                _coordinate(vertex[1], f"vertex {i + 1} lon"),
            ]
        )
    if len(vertices) > 1 and [e7(v) for v in vertices[0]] == [e7(v) for v in vertices[-1]]:
        vertices.pop()  # a closed ring (GeoJSON's habit): the autopilot wants each vertex once
    if len(vertices) < POLYGON_MIN_VERTICES:
        raise FenceError(
            f"a polygon needs at least {POLYGON_MIN_VERTICES} vertices (got {len(vertices)})"
        )
    if len(vertices) > POLYGON_MAX_VERTICES:
        raise FenceError(
            f"a polygon may have at most {POLYGON_MAX_VERTICES} vertices (got {len(vertices)})"
        )
    points = unwrapped(vertices)
    ints = [(e7(lat), e7(lon)) for lat, lon in points]
    for i in range(len(ints)):
        if ints[i] == ints[i - 1]:
            raise FenceError(f"vertex {i + 1 if i else len(ints)} repeats the vertex before it")
    if any(
        abs(abs(_wrap(b[1] - a[1])) - 180.0) < 1e-9
        for a, b in zip(points, points[1:] + points[:1], strict=True)
    ):
        raise FenceError("an edge spanning 180° of longitude is ambiguous; add a vertex on it")
    close = points[-1][1] + _wrap(points[0][1] - points[-1][1]) - points[0][1]
    if abs(close) > 1e-6:
        raise FenceError("a polygon around a pole is not supported; draw it as two")
    if why := _simple(ints):
        raise FenceError(f"the polygon {why}")
    if autopilot and crosses_antimeridian(vertices):
        raise FenceError(
            "the polygon crosses the 180° meridian, which ArduPilot's fence cannot hold "
            "(it would enforce it the long way round the world)"
        )
    return vertices


def _circle(value: Any) -> dict[str, float]:
    if not isinstance(value, Mapping):
        raise FenceError("circle must be an object {lat, lon, radius_m}")
    unknown = set(value) - {"lat", "lon", "radius_m"}
    if unknown:
        raise FenceError(
            f"circle has unknown field {sorted(unknown)[0]!r} (allowed: lat, lon, radius_m)"
        )
    lat, lon = _coordinate(value.get("lat"), "lat"), _coordinate(value.get("lon"), "lon")
    radius = _number(value.get("radius_m"), "radius_m")
    if not 0 < radius <= RADIUS_MAX_M:
        raise FenceError(f"radius_m must be above 0 and at most {RADIUS_MAX_M:g} (got {radius:g})")
    return {"lat": lat, "lon": lon, "radius_m": radius}


def clean_fence(value: Any, *, autopilot: bool = False) -> dict[str, Any]:
    """One fence in the wire shape, checked and normalised; raises :class:`FenceError`.

    ``autopilot``: it is to be loaded into ArduPilot, which cannot hold a polygon across the
    180° meridian.
    """
    if not isinstance(value, Mapping):
        raise FenceError("a fence must be an object {id, name, inclusion, polygon | circle}")
    unknown = set(value) - {"id", "name", "inclusion", *SHAPES}
    if unknown:
        raise FenceError(
            f"unknown field {sorted(unknown)[0]!r} (allowed: id, name, inclusion, polygon, circle)"
        )
    fence_id, name, inclusion = value.get("id"), value.get("name", ""), value.get("inclusion")
    if fence_id is not None and (isinstance(fence_id, bool) or not isinstance(fence_id, int)):
        raise FenceError(f"id must be a whole number or null (got {fence_id!r})")
    if not isinstance(name, str) or len(name) > NAME_MAX:
        raise FenceError(f"name must be text of at most {NAME_MAX} characters")
    if not isinstance(inclusion, bool):
        raise FenceError("inclusion must be true (stay inside) or false (stay out)")
    shapes = [s for s in SHAPES if value.get(s) is not None]
    if len(shapes) != 1:
        raise FenceError("a fence has either a polygon or a circle")
    shape = (
        {"polygon": _polygon(value["polygon"], autopilot=autopilot)}
        if shapes == ["polygon"]
        else {"circle": _circle(value["circle"])}
    )
    return {"id": fence_id, "name": name, "inclusion": inclusion, **shape}


def mavlink_item_count(fences: Sequence[Mapping[str, Any]]) -> int:
    """MAVLink fence items the set takes: one per polygon vertex, one per circle."""
    return sum(len(f["polygon"]) if "polygon" in f else 1 for f in fences)


def storage_bytes(fences: Sequence[Mapping[str, Any]]) -> int:
    """Bytes of ArduPilot's fence storage the set takes (see FENCE_STORAGE_BYTES)."""
    body = sum(
        POLYGON_BYTES + VERTEX_BYTES * len(f["polygon"]) if "polygon" in f else CIRCLE_BYTES
        for f in fences
    )
    return HEADER_BYTES + body + END_BYTES


def _describe(index: int, raw: Any) -> str:
    name = raw.get("name") if isinstance(raw, Mapping) else None
    return f"fence {index + 1}" + (f" ({name})" if isinstance(name, str) and name else "")


def clean_fences(value: Any, *, autopilot: bool = True) -> list[dict[str, Any]]:
    """A whole fence set (the ``fences`` of a ``fence`` command), checked as ArduPilot would
    store it: each fence (:func:`clean_fence`), then the items and bytes against its fence
    storage. Raises :class:`FenceError` naming the fence at fault."""
    if not isinstance(value, list | tuple) or not value:
        raise FenceError("fences must be a non-empty list of fences")
    fences = []
    for i, raw in enumerate(value):
        try:
            fences.append(clean_fence(raw, autopilot=autopilot))
        except FenceError as exc:
            raise FenceError(f"{_describe(i, raw)}: {exc}") from None
    if autopilot:
        items, size = mavlink_item_count(fences), storage_bytes(fences)
        if items > FENCE_MAX_ITEMS or size > FENCE_STORAGE_BYTES:
            raise FenceError(
                f"the fences need {items} autopilot items and {size} bytes; ArduPilot keeps at "
                f"most {FENCE_MAX_ITEMS} items in {FENCE_STORAGE_BYTES} bytes of fence storage "
                "(a vertex takes 8 bytes, a circle 13): use fewer vertices"
            )
    return fences


# -- the server's GeoJSON ------------------------------------------------------------------


def from_geojson(geometry: Any, radius_m: float | None = None) -> dict[str, Any]:
    """The shape part of a fence from the server's geometry (vessels.Fence): a GeoJSON Polygon
    ([lon, lat], outer ring only) → ``{"polygon": [[lat, lon], ...]}``, a Point with
    ``radius_m`` → ``{"circle": {...}}``. Raises :class:`FenceError`; checks as
    :func:`clean_fence` does (not for an autopilot)."""
    if not isinstance(geometry, Mapping) or "coordinates" not in geometry:
        raise FenceError("geometry must be a GeoJSON Polygon, or a Point with radius_m")
    kind, coordinates = geometry.get("type"), geometry["coordinates"]
    if kind == "Polygon":
        if radius_m is not None:
            raise FenceError("radius_m is for a circle (a Point), not a Polygon")
        if not isinstance(coordinates, list | tuple) or not coordinates:
            raise FenceError("a Polygon needs its ring of [lon, lat] positions")
        if len(coordinates) > 1:
            raise FenceError(
                "a polygon with holes is not supported; draw the hole as an exclusion fence"
            )
        ring = coordinates[0]
        if not isinstance(ring, list | tuple) or not all(
            isinstance(p, list | tuple) and len(p) >= 2 for p in ring
        ):
            raise FenceError("a Polygon's ring must be a list of [lon, lat] positions")
        shape: dict[str, Any] = {"polygon": [[p[1], p[0]] for p in ring]}
    elif kind == "Point":
        if not isinstance(coordinates, list | tuple) or len(coordinates) < 2:
            raise FenceError("a Point needs [lon, lat]")
        if radius_m is None:
            raise FenceError("a circle (a Point) needs radius_m")
        shape = {"circle": {"lat": coordinates[1], "lon": coordinates[0], "radius_m": radius_m}}
    else:
        raise FenceError(f"geometry must be a Polygon or a Point (got {kind!r})")
    fence = clean_fence({"name": "", "inclusion": True, **shape})
    return {key: fence[key] for key in shape}


def wire_fence(
    *, id: int | None, name: str, inclusion: bool, geometry: Any, radius_m: float | None
) -> dict[str, Any]:
    """A stored fence (vessels.Fence's fields) in the wire shape."""
    return {"id": id, "name": name, "inclusion": inclusion, **from_geojson(geometry, radius_m)}


# -- geometry -----------------------------------------------------------------------------------


def _in_polygon(points: list[tuple[float, float]], lat: float, lon: float) -> bool:
    """Ray casting (even-odd) in latitude/longitude, over vertices from :func:`unwrapped`,
    trying the point once for each turn of longitude within the polygon's span (a polygon
    across 180° spans lon > 180 or < -180). Two turns cannot both be inside: copies of a
    simple polygon one turn apart do not overlap. A point on a vertex or an edge is a valid
    answer either way, never an error: ``(lat_i > lat) != (lat_j > lat)`` excludes the
    horizontal edges whose division would be by zero."""
    lons = [p[1] for p in points]
    return _in_edges(_edges(points), min(lons), max(lons), lat, lon)


def _edges(points: list[tuple[float, float]]) -> list[tuple[float, float, float, float]]:
    """Each edge as (lat_i, lon_i, lat_j, lon_j), j the vertex before i."""
    return [(*points[i], *points[i - 1]) for i in range(len(points))]


def _in_edges(edges: list[tuple[float, float, float, float]], low: float, high: float,
              lat: float, lon: float) -> bool:  # fmt: skip
    """:func:`_in_polygon` over its edges and longitude span, worked out beforehand."""
    for turn in range(math.ceil((low - lon) / 360.0), math.floor((high - lon) / 360.0) + 1):
        x = lon + 360.0 * turn
        inside = False
        for yi, xi, yj, xj in edges:
            if (yi > lat) != (yj > lat) and x < xi + (lat - yi) * (xj - xi) / (yj - yi):
                inside = not inside
        if inside:
            return True
    return False


def contains(fence: Mapping[str, Any], lat: float, lon: float) -> bool:
    """Whether (lat, lon) is inside the fence's area (whatever its inclusion): a polygon by
    ray casting (concave ones too, right across the 180° meridian), a circle by great-circle
    distance (within ``radius_m``, edge included). ``fence`` is in the wire shape, as
    :func:`clean_fence` or :func:`wire_fence` give it."""
    if "circle" in fence and fence["circle"] is not None:
        c = fence["circle"]
        return distance_m(c["lat"], c["lon"], lat, lon) <= c["radius_m"]
    return _in_polygon(unwrapped(fence["polygon"]), lat, lon)


def containment(fence: Mapping[str, Any]) -> Callable[[float, float], bool]:
    """:func:`contains` for one fence, asked about many points: the same answers, with the
    polygon unwrapped once and points beyond its latitudes (or a circle's) answered at once.
    The alerts evaluator asks it about every fix of every vessel a fence rule watches."""
    if "circle" in fence and fence["circle"] is not None:
        c = fence["circle"]
        clat, clon, radius = c["lat"], c["lon"], c["radius_m"]
        # A great circle is never shorter than its north-south leg, R * |dlat| (radians); the
        # margin keeps the shortcut clear of the haversine's rounding at the edge.
        reach = (radius * (1 + 1e-9) + 1e-6) / (math.radians(1.0) * EARTH_RADIUS_M)
        # ... and never longer than the haversine's bound with sin(x) <= x and cos(lat) <= 1:
        # within dlat^2 + cos(clat) dlon^2 <= (2 sin(radius / 2R))^2 (radians) is inside,
        # with a margin far beyond rounding. (Longitudes unwrapped only make it larger.)
        half = radius / (2 * EARTH_RADIUS_M)
        near = (2 * math.sin(half)) ** 2 * (1 - 1e-6) if half < math.pi / 2 else 0.0
        cos_c, rad = math.cos(math.radians(clat)), math.radians(1.0)

        def in_circle(lat: float, lon: float) -> bool:
            dlat = lat - clat
            if abs(dlat) > reach:
                return False
            dlon = lon - clon
            if (dlat * dlat + cos_c * dlon * dlon) * rad * rad <= near:
                return True
            return distance_m(clat, clon, lat, lon) <= radius

        return in_circle
    points = unwrapped(fence["polygon"])
    south, north = min(p[0] for p in points), max(p[0] for p in points)
    edges, low, high = _edges(points), min(p[1] for p in points), max(p[1] for p in points)

    def in_polygon(lat: float, lon: float) -> bool:
        # Outside its latitudes no edge straddles the point's ray: ray casting says outside.
        if lat < south or lat > north:
            return False
        return _in_edges(edges, low, high, lat, lon)

    return in_polygon


def breached(fences: Sequence[Mapping[str, Any]], lat: float, lon: float) -> bool:
    """Whether a boat at (lat, lon) breaches the set, by ArduPilot's rule: outside any
    inclusion fence (inclusions intersect: it must be inside all of them) or inside any
    exclusion fence. No fences, no breach."""
    return any(contains(f, lat, lon) != f["inclusion"] for f in fences)


def boundary_distance_m(fence: Mapping[str, Any], lat: float, lon: float) -> float:
    """Metres from (lat, lon) to the fence's edge (flat-earth around the point: fine for the
    few kilometres a fence spans). Rover takes its FENCE_ACTION within 100 m of the fence
    and just holds farther out (Rover/fence.cpp); the simulator judges by this."""
    if "circle" in fence and fence["circle"] is not None:
        c = fence["circle"]
        return abs(distance_m(c["lat"], c["lon"], lat, lon) - c["radius_m"])
    scale = math.radians(1.0) * EARTH_RADIUS_M
    cos_lat = math.cos(math.radians(lat))
    points = unwrapped(fence["polygon"])
    shift = 360.0 * round((sum(p[1] for p in points) / len(points) - lon) / 360.0)
    xy = [((p[1] - lon - shift) * cos_lat * scale, (p[0] - lat) * scale) for p in points]
    best = math.inf
    for i in range(len(xy)):
        (ax, ay), (bx, by) = xy[i - 1], xy[i]
        dx, dy = bx - ax, by - ay
        length2 = dx * dx + dy * dy
        t = 0.0 if length2 == 0 else max(0.0, min(1.0, -(ax * dx + ay * dy) / length2))
        best = min(best, math.hypot(ax + t * dx, ay + t * dy))
    return best
