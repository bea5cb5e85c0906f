"""The offline coastline's pure steps (issue 18 §1): Natural Earth land, as the npm package
world-atlas carries it (TopoJSON), cut into cells a map fetches only where it looks.

`manage.py build_coastline` reads the files and writes the results; everything here is
arithmetic on lists, so the tests can drive it with made-up polygons.

Each output file is itself a small TopoJSON topology of one cell (the whole world for the
coarse levels): a ``land`` object (polygons, clipped to the cell, for the fill) and a
``coastline`` object (lines) that shares the land's arcs except those running along the cell's
edge, so a coast drawn cell by cell shows no seams where the cells meet. Coordinates are
quantised to an integer grid of the cell (``q`` steps a side) and delta-encoded, as TopoJSON
does: a few bytes a point.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

Point = tuple[float, float]  # (lon, lat), degrees
Ring = list[Point]  # open: the last point is not the first again
Polygon = list[Ring]  # outer ring, then holes
IntPoint = tuple[int, int]


@dataclass(frozen=True, order=True)
class Cell:
    """A lon/lat box: [west, east] × [south, north], degrees."""

    west: float
    south: float
    east: float
    north: float

    @property
    def name(self) -> str:
        """s35e115 for the cell whose south-west corner is 35°S 115°E; "world" for the world."""
        if (self.west, self.south, self.east, self.north) == (-180, -90, 180, 90):
            return "world"
        lat, lon = round(self.south), round(self.west)
        return f"{'s' if lat < 0 else 'n'}{abs(lat)}{'w' if lon < 0 else 'e'}{abs(lon)}"


WORLD = Cell(-180, -90, 180, 90)


def decode_arcs(topology: dict[str, Any]) -> list[list[Point]]:
    """A topology's arcs in degrees (undoing the quantisation's deltas and transform)."""
    transform = topology.get("transform")
    arcs = []
    for arc in topology["arcs"]:
        if transform is None:
            arcs.append([(float(p[0]), float(p[1])) for p in arc])
            continue
        (sx, sy), (tx, ty) = transform["scale"], transform["translate"]
        x = y = 0
        points = []
        for p in arc:
            x, y = x + p[0], y + p[1]
            points.append((x * sx + tx, y * sy + ty))
        arcs.append(points)
    return arcs


def stitch(arcs: Sequence[Sequence[Point]], indexes: Iterable[int]) -> list[Point]:
    """One line or ring from arc indexes (~i is arc i reversed); shared ends kept once."""
    points: list[Point] = []
    for i in indexes:
        arc = list(arcs[i]) if i >= 0 else list(reversed(arcs[~i]))
        points.extend(arc[1:] if points else arc)
    return points


def polygons(topology: dict[str, Any], name: str) -> list[Polygon]:
    """Every polygon of the object `name` (a GeometryCollection, a Polygon or a MultiPolygon)."""
    arcs = decode_arcs(topology)
    found: list[Polygon] = []

    def add(geometry: dict[str, Any]) -> None:
        kind = geometry.get("type")
        if kind == "GeometryCollection":
            for g in geometry["geometries"]:
                add(g)
        elif kind in ("Polygon", "MultiPolygon"):
            for rings in [geometry["arcs"]] if kind == "Polygon" else geometry["arcs"]:
                polygon = [open_ring(stitch(arcs, r)) for r in rings]
                if polygon and len(polygon[0]) >= 3:
                    found.append([r for r in polygon if len(r) >= 3])

    add(topology["objects"][name])
    return found


def open_ring(points: list[Point]) -> Ring:
    return points[:-1] if len(points) > 1 and points[0] == points[-1] else points


def _clip_edge(ring: Ring, inside: Any, cross: Any) -> Ring:
    """One Sutherland–Hodgman pass: the part of `ring` on the inner side of one edge."""
    out: Ring = []
    for i, current in enumerate(ring):
        previous = ring[i - 1]
        if inside(current):
            if not inside(previous):
                out.append(cross(previous, current))
            out.append(current)
        elif inside(previous):
            out.append(cross(previous, current))
    return out


def _at_x(x: float) -> Any:
    def cross(a: Point, b: Point) -> Point:
        return (x, a[1] + (b[1] - a[1]) * (x - a[0]) / (b[0] - a[0]))

    return cross


def _at_y(y: float) -> Any:
    def cross(a: Point, b: Point) -> Point:
        return (a[0] + (b[0] - a[0]) * (y - a[1]) / (b[1] - a[1]), y)

    return cross


def clip_ring(ring: Ring, cell: Cell) -> Ring:
    """The ring clipped to the cell (Sutherland–Hodgman). A concave ring may come back with
    edges running along the cell's border and back: they enclose nothing, and the coastline
    leaves out every edge on the border."""
    for inside, cross in (
        (lambda p: p[0] >= cell.west, _at_x(cell.west)),
        (lambda p: p[0] <= cell.east, _at_x(cell.east)),
        (lambda p: p[1] >= cell.south, _at_y(cell.south)),
        (lambda p: p[1] <= cell.north, _at_y(cell.north)),
    ):
        if not ring:
            break
        ring = _clip_edge(ring, inside, cross)
    return ring


def quantise(value: float, origin: float, step: float, q: int) -> int:
    """The grid line nearest `value` (origin + k·step), held to [0, q]."""
    return min(q, max(0, round((value - origin) / step)))


def quantise_ring(ring: Ring, cell: Cell, q: int) -> list[IntPoint]:
    """The ring on the cell's q×q grid, repeated points dropped; [] when fewer than 3 remain."""
    sx, sy = (cell.east - cell.west) / q, (cell.north - cell.south) / q
    out: list[IntPoint] = []
    for lon, lat in ring:
        p = (quantise(lon, cell.west, sx, q), quantise(lat, cell.south, sy, q))
        if not out or out[-1] != p:
            out.append(p)
    while len(out) > 1 and out[0] == out[-1]:
        out.pop()
    return out if len(out) >= 3 else []


def twice_area(ring: Sequence[tuple[float, float]]) -> float:
    """Twice the ring's signed area (shoelace): positive when counter-clockwise."""
    return sum(ring[i - 1][0] * ring[i][1] - ring[i][0] * ring[i - 1][1] for i in range(len(ring)))


def on_border(a: IntPoint, b: IntPoint, q: int) -> bool:
    """True for an edge that runs along the cell's border: made by the cut, not a coast."""
    return (a[0] == b[0] and a[0] in (0, q)) or (a[1] == b[1] and a[1] in (0, q))


def runs(ring: list[IntPoint], q: int) -> list[tuple[bool, list[IntPoint]]]:
    """The closed ring as runs of consecutive edges, (is_coast, points), in order; one run
    (its first point repeated at the end) when no edge lies on the border."""
    n = len(ring)
    coast = [not on_border(ring[i], ring[(i + 1) % n], q) for i in range(n)]
    if all(coast) or not any(coast):
        return [(coast[0], [*ring, ring[0]])]
    # Start where the kind of edge changes, so no run is split across the ring's start.
    start = next(i for i in range(n) if coast[i] != coast[i - 1])
    out: list[tuple[bool, list[IntPoint]]] = []
    for k in range(n):
        i = (start + k) % n
        if not out or out[-1][0] != coast[i]:
            out.append((coast[i], [ring[i]]))
        out[-1][1].append(ring[(i + 1) % n])
    return out


def delta(points: list[IntPoint]) -> list[list[int]]:
    """TopoJSON's delta encoding: the first point, then each step from the one before."""
    out, px, py = [], 0, 0
    for x, y in points:
        out.append([x - px, y - py])
        px, py = x, y
    return out


def cell_topology(polys: list[list[list[IntPoint]]], cell: Cell, q: int) -> dict[str, Any]:
    """A TopoJSON topology of one cell: `land` (the polygons) and `coastline` (their edges
    that are not on the cell's border), sharing arcs."""
    arcs: list[list[list[int]]] = []
    land: list[list[list[int]]] = []
    coast: list[list[int]] = []
    for poly in polys:
        rings = []
        for ring in poly:
            indexes = []
            for is_coast, points in runs(ring, q):
                indexes.append(len(arcs))
                if is_coast:
                    coast.append([len(arcs)])
                arcs.append(delta(points))
            rings.append(indexes)
        land.append(rings)
    return {
        "type": "Topology",
        "bbox": [cell.west, cell.south, cell.east, cell.north],
        "transform": {
            "scale": [(cell.east - cell.west) / q, (cell.north - cell.south) / q],
            "translate": [cell.west, cell.south],
        },
        "objects": {
            "land": {"type": "MultiPolygon", "arcs": land},
            "coastline": {"type": "MultiLineString", "arcs": coast},
        },
        "arcs": arcs,
    }


def bbox(ring: Ring) -> Cell:
    lons, lats = [p[0] for p in ring], [p[1] for p in ring]
    return Cell(min(lons), min(lats), max(lons), max(lats))


def cells_over(box: Cell, size: float) -> Iterator[Cell]:
    """The size°×size° cells (aligned on multiples of size) that the box touches."""
    lat = math.floor(box.south / size) * size
    while lat < box.north or lat == box.south:
        lon = math.floor(box.west / size) * size
        while lon < box.east or lon == box.west:
            yield Cell(lon, lat, lon + size, lat + size)
            lon += size
        lat += size


def clip_polygon(poly: Polygon, cell: Cell) -> Polygon:
    """The polygon's part in the cell, holes and all; [] when its outer ring is all outside."""
    outer = clip_ring(poly[0], cell)
    if len(outer) < 3 or twice_area(outer) == 0:  # nothing, or only along the cell's edge
        return []
    return [outer, *(h for h in (clip_ring(h, cell) for h in poly[1:]) if len(h) >= 3)]


def quantise_polygon(poly: Polygon, cell: Cell, q: int) -> list[list[IntPoint]]:
    """The polygon on the cell's grid; [] when its outer ring encloses nothing there."""
    outer = quantise_ring(poly[0], cell, q)
    if not outer or twice_area(outer) == 0:
        return []
    holes = [quantise_ring(h, cell, q) for h in poly[1:]]
    return [outer, *(h for h in holes if h and twice_area(h) != 0)]


def unwrap(ring: Ring) -> Ring:
    """The ring with its longitudes made continuous: an edge across the antimeridian (179° to
    -179°, two degrees on the globe) would otherwise be drawn round the world. A ring round a
    pole (Antarctica's) ends a turn away from its start: it is closed along the pole."""
    out: Ring = [ring[0]]
    offset = 0.0
    for (prev, _), (lon, lat) in zip(ring, ring[1:], strict=False):
        offset += _turn(lon - prev)
        out.append((lon + offset, lat))
    offset += _turn(ring[0][0] - ring[-1][0])
    if offset:
        pole = -90.0 if sum(p[1] for p in ring) < 0 else 90.0
        first = ring[0]
        out += [(first[0] + offset, first[1]), (first[0] + offset, pole), (first[0], pole)]
    return out


def _turn(step: float) -> float:
    return -360.0 if step > 180 else 360.0 if step < -180 else 0.0


def planar(poly: Polygon) -> Polygon:
    """The polygon unwrapped (`unwrap`), its holes moved by whole turns to lie in its outer."""
    outer = unwrap(poly[0])
    centre = (bbox(outer).west + bbox(outer).east) / 2
    holes = []
    for hole in poly[1:]:
        h = unwrap(hole)
        shift = 360.0 * round((centre - (bbox(h).west + bbox(h).east) / 2) / 360)
        holes.append([(lon + shift, lat) for lon, lat in h] if shift else h)
    return [outer, *holes]


def _wrapped(cell: Cell, piece: Polygon) -> tuple[Cell, Polygon]:
    """A cell past the antimeridian (and its piece) moved by whole turns into [-180°, 180°]."""
    shift = -360.0 * math.floor((cell.west + 180) / 360)
    if not shift:
        return cell, piece
    moved = Cell(cell.west + shift, cell.south, cell.east + shift, cell.north)
    return moved, [[(lon + shift, lat) for lon, lat in ring] for ring in piece]


def pieces(poly: Polygon, size: float | None) -> Iterator[tuple[Cell, Polygon]]:
    """(cell, the polygon's part in it) for every cell the polygon reaches; size None: the
    world. The polygon is unwrapped first, and a part past ±180° is moved back a turn. A
    continent is cut into rows first and each row into cells: far fewer points clipped than
    cell by cell."""
    poly = planar(poly)
    box = bbox(poly[0])
    if size is None:
        first, last = (math.floor((x + 180) / 360) for x in (box.west, box.east))
        for k in range(first, last + 1):
            copy = Cell(-180.0 + 360 * k, -90.0, 180.0 + 360 * k, 90.0)
            piece = clip_polygon(poly, copy)
            if piece:
                yield _wrapped(copy, piece)
        return
    for row in cells_over(Cell(box.west, box.south, box.west, box.north), size):
        band = clip_polygon(poly, Cell(box.west, row.south, box.east, row.north))
        if band:
            west, east = bbox(band[0]).west, bbox(band[0]).east
            for cell in cells_over(Cell(west, row.south, east, row.south), size):
                piece = clip_polygon(band, cell)
                if piece:
                    yield _wrapped(cell, piece)


def split(polys: Iterable[Polygon], size: float | None, q: int) -> dict[Cell, dict[str, Any]]:
    """{cell: topology} for every cell with land; size None: one cell, the world."""
    found: dict[Cell, list[list[list[IntPoint]]]] = {}
    for poly in polys:
        for cell, piece in pieces(poly, size):
            quantised = quantise_polygon(piece, cell, q)
            if quantised:
                found.setdefault(cell, []).append(quantised)
    return {cell: cell_topology(p, cell, q) for cell, p in sorted(found.items())}
