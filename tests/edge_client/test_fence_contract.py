"""The fence contract (edge_client/contract/fence.py): the wire shape's checks, the server's
GeoJSON, and the geometry the shore and the autopilot share, with hypothesis: concave
polygons, the 180° meridian, circles, points on vertices."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from edge_client.contract import fence as shape
from edge_client.contract.fence import (
    FenceError,
    breached,
    clean_fence,
    clean_fences,
    containment,
    contains,
    from_geojson,
    wire_fence,
)
from edge_client.contract.geo import distance_m, offset


def polygon(vertices, inclusion=True, name="p"):
    return {"id": None, "name": name, "inclusion": inclusion, "polygon": vertices}


def circle(lat, lon, radius_m, inclusion=True, name="c"):
    return {"id": None, "name": name, "inclusion": inclusion,
            "circle": {"lat": lat, "lon": lon, "radius_m": radius_m}}  # fmt: skip


def wrap(lon: float) -> float:
    return (lon + 180.0) % 360.0 - 180.0


# A harbour as an inclusion fence for the water, with a peninsula jutting in from the east
# shore: a concave polygon (vertices [lat, lon], round from the south-west corner).
COAST = [
    [-32.10, 115.60], [-32.10, 115.75], [-32.06, 115.75],  # the south shore, the east shore
    [-32.06, 115.70], [-32.02, 115.70], [-32.02, 115.75],  # round the peninsula's tip
    [-31.98, 115.75], [-31.98, 115.60],  # the east shore again, the harbour's mouth
]  # fmt: skip


def test_a_concave_coastline_keeps_the_water_in_and_the_peninsula_out():
    water = polygon(COAST)
    assert contains(water, -32.04, 115.65)  # off the peninsula's tip
    assert contains(water, -32.08, 115.72)  # the bay south of it
    assert contains(water, -32.00, 115.72)  # the bay north of it
    assert not contains(water, -32.04, 115.72)  # on the peninsula
    assert not contains(water, -32.04, 115.76)  # ashore, east of it all
    assert breached([water], -32.04, 115.72) and not breached([water], -32.08, 115.72)
    assert clean_fences([water])  # concave is fine; only a crossing is refused


def test_a_polygon_across_180_degrees_takes_the_short_way_round():
    dateline = polygon([[-1, 179], [-1, -179], [1, -179], [1, 179]])
    assert contains(dateline, 0, 179.5) and contains(dateline, 0, -179.5)
    assert contains(dateline, 0, 180.0) and contains(dateline, 0, -180.0)
    assert not contains(dateline, 0, 0) and not contains(dateline, 0, 178.9)
    assert shape.crosses_antimeridian(dateline["polygon"])
    assert clean_fences([dateline], autopilot=False)  # the shore watches it
    with pytest.raises(FenceError, match="crosses the 180° meridian, which ArduPilot"):
        clean_fences([dateline])  # the autopilot would hold it the long way round


def test_a_circle_across_180_degrees():
    fiji = circle(-17.0, 179.999, 2000)
    assert contains(fiji, -17.0, -179.99) and not contains(fiji, -17.0, -179.9)
    assert clean_fences([fiji])  # ArduPilot measures a circle's distance across 180° too


@st.composite
def stars(draw):
    """A star-shaped polygon around a centre at any latitude within ±60° and any longitude,
    often within a degree of 180° so that it crosses it: concave, simple, every ray from the
    centre leaves it once, and (no gap between vertex bearings is half a turn) the centre is
    inside."""
    lat0 = draw(st.floats(-60, 60))
    near_180 = st.floats(179, 180, exclude_max=True) | st.floats(-180, -179)
    lon0 = draw(st.floats(-180, 180, exclude_max=True) | near_180)
    n = draw(st.integers(3, 24))
    gaps = draw(st.lists(st.floats(0.6, 1.0), min_size=n, max_size=n))
    turn = draw(st.floats(0, 2 * math.pi))
    angles, total = [], sum(gaps)
    for g in gaps:
        angles.append(turn)
        turn += 2 * math.pi * g / total
    radii = draw(st.lists(st.floats(0.05, 1.0), min_size=n, max_size=n))
    ring = [
        [lat0 + r * math.cos(a), wrap(lon0 + r * math.sin(a))]
        for a, r in zip(angles, radii, strict=True)
    ]
    return (lat0, lon0), ring, list(zip(angles, radii, strict=True))


@settings(max_examples=300, deadline=None)
@given(stars())
def test_points_along_each_vertex_ray_are_inside_short_of_it_and_outside_beyond(star):
    (lat0, lon0), ring, rays = star
    fence = polygon(ring)
    assert clean_fence(fence, autopilot=False)["polygon"]  # a simple polygon, as drawn
    assert contains(fence, lat0, lon0)
    for a, r in rays:
        for k, inside in ((0.9, True), (0.5, True), (1.1, False), (2.0, False)):
            lat, lon = lat0 + k * r * math.cos(a), wrap(lon0 + k * r * math.sin(a))
            assert contains(fence, lat, lon) is inside, (a, r, k)


@settings(max_examples=200, deadline=None)
@given(stars(), st.floats(-360, 360), st.floats(-2, 2), st.floats(-2, 2))
def test_moving_polygon_and_point_east_or_west_changes_nothing(star, shift, dlat, dlon):
    (lat0, lon0), ring, _ = star
    lat, lon = lat0 + dlat, wrap(lon0 + dlon)
    moved = [[v[0], wrap(v[1] + shift)] for v in ring]
    assume(all(abs(abs(wrap(a[1] - b[1])) - 180) > 1e-6 for a, b in zip(ring, moved, strict=True)))
    assert contains(polygon(moved), lat, wrap(lon + shift)) == contains(polygon(ring), lat, lon)


@settings(max_examples=200, deadline=None)
@given(stars(), st.data())
def test_a_point_on_a_vertex_or_an_edge_gives_an_answer_never_an_error(star, data):
    _, ring, _ = star
    fence = polygon(ring)
    i = data.draw(st.integers(0, len(ring) - 1))
    t = data.draw(st.floats(0, 1))
    a, b = ring[i], ring[i - 1]
    on_edge = a[0] + t * (b[0] - a[0]), a[1] + t * wrap(b[1] - a[1])
    assert contains(fence, a[0], a[1]) in (True, False)
    assert contains(fence, on_edge[0], wrap(on_edge[1])) in (True, False)
    assert shape.boundary_distance_m(fence, a[0], a[1]) < 1.0


@settings(max_examples=300, deadline=None)
@given(
    st.floats(-80, 80),
    st.floats(-180, 180),
    st.floats(10, 20_000),
    st.floats(0, 360, exclude_max=True),
)
@example(0.0, 179.9999, 500.0, 90.0)  # across 180°
@example(-32.0, 115.7, 10.0, 0.0)
def test_a_circle_holds_what_is_within_its_radius(lat, lon, radius, bearing):
    fence = circle(lat, lon, radius)
    near = offset(lat, lon, bearing, 0.98 * radius)
    far = offset(lat, lon, bearing, 1.02 * radius)
    assert contains(fence, near[0], wrap(near[1]))
    assert not contains(fence, far[0], wrap(far[1]))
    assert contains(fence, lat, lon)  # its centre
    edge = distance_m(lat, lon, far[0], wrap(far[1]))
    assert shape.boundary_distance_m(fence, far[0], wrap(far[1])) == pytest.approx(edge - radius)


def test_inclusions_intersect_and_any_exclusion_is_a_breach_as_ardupilot_has_it():
    west, east = circle(0, 0, 1000), circle(0, 0.01, 1000)  # overlapping ~1.1 km apart
    both, only_west = (0, 0.005), (0, -0.005)
    assert not breached([west, east], *both)
    assert breached([west, east], *only_west)  # inside one inclusion is not enough
    rock = circle(0, 0.005, 50, inclusion=False)
    assert breached([west, east, rock], *both)
    assert not breached([], *both) and not breached([rock], *only_west)


# -- the wire shape's checks -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("fence", "message"),
    [
        (polygon([[0, 0], [1, 1], [0, 1], [1, 0]]), "crosses itself (edge 1-2 meets edge 3-4)"),
        (polygon([[0, 0], [0, 1]]), "at least 3 vertices (got 2)"),
        (polygon([[0, 0], [0, 1], [0, 1], [1, 1]]), "vertex 3 repeats the vertex before it"),
        (polygon([[0, 0], [0, 2], [0, 1], [1, 1]]), "folds back on itself at vertex 2"),
        (polygon([[0, 0], [0, 1], [0, 2]]), "folds back on itself at vertex 1"),
        (polygon([[0, 0], [91, 1], [1, 1]]), "vertex 2 lat must be between -90 and 90"),
        (polygon([[0, 0], [1, float("nan")], [1, 1]]), "vertex 2 lon must be a finite number"),
        (polygon([[0, 0], [1, True], [1, 1]]), "vertex 2 lon must be a number"),
        (polygon([[80, 0], [80, 120], [80, -120]]), "around a pole is not supported"),
        (polygon([[0, 0], [0, 180], [1, 90]]), "spanning 180° of longitude is ambiguous"),
        (circle(0, 0, 0), "radius_m must be above 0"),
        (circle(0, 0, -5), "radius_m must be above 0"),
        (circle(0, 0, 2e6), "at most 1e+06"),
        ({**circle(0, 0, 5), "polygon": [[0, 0]]}, "either a polygon or a circle"),
        ({**circle(0, 0, 5), "inclusion": "yes"}, "inclusion must be true"),
        ({**circle(0, 0, 5), "colour": "red"}, "unknown field 'colour'"),
        ({**circle(0, 0, 5), "id": 1.5}, "id must be a whole number"),
        ([], "must be an object"),
    ],
)
def test_a_bad_fence_is_refused_with_a_reason(fence, message):
    with pytest.raises(FenceError) as exc:
        clean_fence(fence)
    assert message in str(exc.value)


def test_a_closed_ring_is_opened_and_limits_are_the_autopilots():
    ring = [[0, 0], [0, 1], [1, 1], [0, 0]]
    assert clean_fence(polygon(ring))["polygon"] == [[0, 0], [0, 1], [1, 1]]
    many = [list(offset(0, 0, b * 360 / 300, 1000)) for b in range(256)]
    with pytest.raises(FenceError, match="at most 255 vertices"):
        clean_fence(polygon(many))


def ring_of(n: int) -> list[list[float]]:
    return [list(offset(-32, 115.7, i * 360 / n, 2000)) for i in range(n)]


def test_the_set_must_fit_ardupilots_fence_storage():
    assert shape.storage_bytes([polygon(ring_of(83))]) == 671  # 4 + 2 + 83 × 8 + 1
    assert clean_fences([polygon(ring_of(83))])
    with pytest.raises(FenceError) as exc:
        clean_fences([polygon(ring_of(28)), polygon(ring_of(28)), polygon(ring_of(28), False)])
    assert str(exc.value) == (
        "the fences need 84 autopilot items and 683 bytes; ArduPilot keeps at most 84 items in "
        "672 bytes of fence storage (a vertex takes 8 bytes, a circle 13): use fewer vertices"
    )
    with pytest.raises(FenceError, match="need 84 autopilot items and 679 bytes"):
        clean_fences([polygon(ring_of(84))])
    assert clean_fences([polygon(ring_of(84))], autopilot=False)  # the shore has no such limit
    with pytest.raises(FenceError, match="fence 2 \\(Rock\\): radius_m"):
        clean_fences([polygon(ring_of(5)), circle(0, 0, 0, name="Rock")])
    with pytest.raises(FenceError, match="non-empty list"):
        clean_fences([])


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=6) | st.dictionaries(st.text(max_size=8), inner, max_size=5)
    ),
    max_leaves=30,
)


@settings(max_examples=400, deadline=None)
@given(JSON)
@example({"name": "", "inclusion": True, "polygon": [[0, 0], [0, 1e400], [1, 1]]})
@example({"name": "", "inclusion": True, "circle": {"lat": 0, "lon": 0, "radius_m": 10**400}})
@example([{"name": "x", "inclusion": False, "polygon": [[1, 1], [1, 2], [2, 2]]}])
def test_any_json_is_either_a_fence_set_or_refused_with_a_reason(value):
    try:
        clean_fences(value)
    except FenceError as exc:
        assert str(exc)


# -- the server's GeoJSON ------------------------------------------------------------------


def test_geojson_polygons_and_points_become_the_wire_shape():
    geometry = {
        "type": "Polygon",
        "coordinates": [[[115, -32], [116, -32], [116, -31], [115, -32]]],
    }
    assert from_geojson(geometry) == {"polygon": [[-32, 115], [-32, 116], [-31, 116]]}
    point = {"type": "Point", "coordinates": [115.7, -32.0]}
    assert wire_fence(id=7, name="Rock", inclusion=False, geometry=point, radius_m=50) == circle(
        -32.0, 115.7, 50, inclusion=False, name="Rock"
    ) | {"id": 7}


@pytest.mark.parametrize(
    ("geometry", "radius", "message"),
    [
        ({"type": "Point", "coordinates": [115.7, -32.0]}, None, "needs radius_m"),
        (
            {"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 0]], [[0.2, 0.2]]]},
            None,
            "holes is not supported",
        ),  # fmt: skip
        ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0], [1, 1]]]}, 5, "for a circle"),
        ({"type": "LineString", "coordinates": [[0, 0], [1, 1]]}, None, "Polygon or a Point"),
        ({"type": "Polygon", "coordinates": [[[0, 0], [1, 0]]]}, None, "at least 3 vertices"),
        ("Polygon", None, "must be a GeoJSON Polygon"),
    ],
)
def test_bad_geojson_is_refused_with_a_reason(geometry, radius, message):
    with pytest.raises(FenceError, match=message):
        from_geojson(geometry, radius)


@settings(max_examples=300, deadline=None)
@given(
    stars(),
    st.floats(-89, 89),
    st.floats(-180, 180),
    st.floats(1, 5_000_000),
    st.lists(
        st.tuples(st.floats(-3, 3), st.floats(0, 360, exclude_max=True), st.floats(0, 2.5)),
        min_size=1,
        max_size=20,
    ),
)
@example(((0.0, 0.0), [[-1, -1], [-1, 1], [1, 1], [1, -1]], []), 0.0, 179.9999, 500.0,
         [(0.0, 90.0, 1.0), (1.0, 0.0, 0.0)])  # fmt: skip
def test_containment_answers_as_contains_does(star, lat, lon, radius, probes):
    """The evaluator's per-fence shortcut (alerts/evaluator.py) never answers otherwise."""
    (lat0, lon0), ring, _ = star
    for fence, (clat, clon), size in (
        (circle(lat, lon, radius), (lat, lon), radius),
        (polygon(ring), (lat0, lon0), 200_000.0),
    ):
        test = containment(fence)
        for dlat, bearing, k in probes:
            la, lo = offset(clat, clon, bearing, k * size)
            la, lo = max(-90.0, min(90.0, la + dlat * k)), wrap(lo)
            assert test(la, lo) == contains(fence, la, lo), (la, lo)
