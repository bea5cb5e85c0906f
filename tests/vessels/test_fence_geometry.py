"""A fence's geometry checked and normalised (vessels.fences), and fences read from files
(vessels.missionfiles.fences): QGC .plan geoFence sections and GeoJSON."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vessels import fences
from vessels.errors import VesselsError
from vessels.fences import FenceError
from vessels.missionfiles import fences as fencefiles
from vessels.missionfiles.fences import FenceFileError

SQUARE = [[115.70, -32.00], [115.72, -32.00], [115.72, -32.01], [115.70, -32.01], [115.70, -32.00]]


def polygon(ring):
    return {"type": "Polygon", "coordinates": [ring]}


def test_a_closed_polygon_is_kept_as_given():
    geometry, radius = fences.clean(polygon(SQUARE))
    assert geometry == polygon(SQUARE) and radius is None
    assert fences.vertices(geometry) == [
        (-32.0, 115.7),
        (-32.0, 115.72),
        (-32.01, 115.72),
        (-32.01, 115.7),
    ]
    assert fences.describe(geometry, None) == "polygon, 4 vertices"


def test_a_circle_is_a_point_and_a_radius():
    geometry, radius = fences.clean({"type": "Point", "coordinates": [115.7, -32.0, 5]}, 250)
    assert geometry == {"type": "Point", "coordinates": [115.7, -32.0]}  # altitude dropped
    assert radius == 250.0
    assert fences.describe(geometry, radius) == "circle, 250 m"


@pytest.mark.parametrize(
    ("geometry", "radius", "said"),
    [
        (polygon(SQUARE[:-1]), None, "the ring must be closed"),
        (polygon([SQUARE[0], SQUARE[1], SQUARE[0], SQUARE[0]]), None, "at least 3 distinct"),
        ({"type": "Polygon", "coordinates": [SQUARE, SQUARE]}, None, "holes are not supported"),
        (polygon([[200, -32], [115.7, -32], [115.7, -33], [200, -32]]), None, "outside"),
        (polygon([["a", -32], [1, 1], [2, 2], ["a", -32]]), None, "must be numbers"),
        (polygon(SQUARE), 100, "radius_m is for a circle"),
        ({"type": "Point", "coordinates": [115.7, -32.0]}, None, "needs radius_m"),
        ({"type": "Point", "coordinates": [115.7, -32.0]}, 0, "radius_m 0 is not within"),
        ({"type": "Point", "coordinates": [115.7, -32.0]}, float("nan"), "is not within"),
        ({"type": "LineString", "coordinates": SQUARE}, None, "Polygon or Point"),
        ([1, 2], None, "must be a GeoJSON object"),
    ],
)
def test_a_bad_fence_is_refused_saying_why(geometry, radius, said):
    with pytest.raises(FenceError) as caught:
        fences.clean(geometry, radius)
    assert said in caught.value.message


def test_too_many_vertices_are_refused():
    ring = [[115 + i / 1000, -32 + (i % 2) / 1000] for i in range(fences.FENCE_MAX_VERTICES + 1)]
    with pytest.raises(FenceError, match=f"at most {fences.FENCE_MAX_VERTICES} vertices"):
        fences.clean(polygon([*ring, ring[0]]))


# Any JSON value either is a fence or is refused with the fence error (never a TypeError).
json_values = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=5),
    lambda inner: (
        st.lists(inner, max_size=6) | st.dictionaries(st.text(max_size=12), inner, max_size=4)
    ),
    max_leaves=30,
)


@given(geometry=json_values, radius=json_values)
def test_any_input_is_a_fence_or_a_fence_error(geometry, radius):
    try:
        fences.clean(geometry, radius)
    except FenceError:
        pass


@given(
    ring=st.lists(
        st.tuples(st.floats(-180, 180), st.floats(-90, 90)).map(list), min_size=3, max_size=12
    ),
    shape=st.sampled_from(["Polygon", "Point"]),
)
def test_any_polygon_shaped_input_is_a_fence_or_a_fence_error(ring, shape):
    geometry = {"type": shape, "coordinates": [[*ring, ring[0]]] if shape == "Polygon" else ring[0]}
    try:
        cleaned, _ = fences.clean(geometry, 10 if shape == "Point" else None)
    except FenceError:
        return
    assert fences.clean(cleaned, 10 if shape == "Point" else None)[0] == cleaned  # idempotent


PLAN = {
    "fileType": "Plan",
    "version": 1,
    "groundStation": "QGroundControl",
    "mission": {"items": [], "plannedHomePosition": [-32.0, 115.7, 0]},
    "geoFence": {
        "version": 2,
        "polygons": [
            {"inclusion": True, "version": 1,
             "polygon": [[-32.00, 115.70], [-32.00, 115.72], [-32.01, 115.72], [-32.01, 115.70]]},
            {"inclusion": False, "version": 1,
             "polygon": [[-32.004, 115.705], [-32.004, 115.706], [-32.005, 115.706]]},
        ],
        "circles": [
            {"inclusion": False, "version": 1,
             "circle": {"center": [-32.006, 115.71], "radius": 40.5}},
        ],
    },
    "rallyPoints": {"points": [], "version": 2},
}  # fmt: skip


def test_a_qgc_plan_gives_its_polygons_and_circles_with_their_inclusion():
    found = fencefiles.load(json.dumps(PLAN))
    assert [(f.inclusion, f.geometry["type"], f.radius_m) for f in found] == [
        (True, "Polygon", None),
        (False, "Polygon", None),
        (False, "Point", 40.5),
    ]
    # QGC's open ring of [lat, lon] becomes a closed GeoJSON ring of [lon, lat].
    assert found[0].geometry == polygon(SQUARE)
    assert found[2].geometry["coordinates"] == [115.71, -32.006]


def test_a_plan_without_a_fence_or_with_a_bad_one_says_so():
    with pytest.raises(FenceFileError, match='no "geoFence"'):
        fencefiles.load(json.dumps({"fileType": "Plan", "mission": {"items": []}}))
    bad = json.loads(json.dumps(PLAN))
    bad["geoFence"]["polygons"][1]["polygon"] = [[-32, 115.7], [-32, 115.7]]
    bad["geoFence"]["circles"][0]["circle"]["radius"] = -1
    with pytest.raises(FenceFileError) as caught:
        fencefiles.load(json.dumps(bad))
    assert len(caught.value.problems) == 2
    assert caught.value.problems[0].startswith("geoFence polygon 2:")
    assert caught.value.problems[1].startswith("geoFence circle 1: radius_m -1")


def test_geojson_features_polygons_multipolygons_and_circles():
    collection = {
        "type": "FeatureCollection",
        "features": [
            {"type": "Feature", "properties": {"name": "Harbour", "inclusion": True},
             "geometry": polygon(SQUARE)},
            {"type": "Feature", "properties": {"inclusion": False, "radius_m": 30, "name": "Wreck"},
             "geometry": {"type": "Point", "coordinates": [115.71, -32.005]}},
            {"type": "Feature", "properties": {"name": "Reefs", "inclusion": False},
             "geometry": {"type": "MultiPolygon", "coordinates": [[SQUARE], [SQUARE[::-1]]]}},
        ],
    }  # fmt: skip
    found = fencefiles.load(json.dumps(collection))
    assert [(f.name, f.inclusion, f.radius_m) for f in found] == [
        ("Harbour", True, None),
        ("Wreck", False, 30.0),
        ("Reefs 1", False, None),
        ("Reefs 2", False, None),
    ]
    # A bare geometry is one fence, an inclusion one.
    (bare,) = fencefiles.load(json.dumps(polygon(SQUARE)), format="geojson")
    assert bare.inclusion and bare.geometry == polygon(SQUARE)


def test_geojson_that_is_no_fence_is_refused():
    line = {"type": "Feature", "geometry": {"type": "LineString", "coordinates": SQUARE}}
    with pytest.raises(FenceFileError, match="a LineString is no fence"):
        fencefiles.load(json.dumps(line))
    with pytest.raises(FenceFileError, match="invalid JSON"):
        fencefiles.load(b"{nope")
    with pytest.raises(FenceFileError, match="no fence"):
        fencefiles.load(json.dumps({"type": "FeatureCollection", "features": []}))
    flag = {"type": "Feature", "properties": {"inclusion": "yes"}, "geometry": polygon(SQUARE)}
    with pytest.raises(FenceFileError, match="inclusion must be true or false"):
        fencefiles.load(json.dumps(flag))


@given(content=st.binary(max_size=200) | json_values.map(json.dumps))
def test_any_file_is_fences_or_a_vessels_error(content):
    try:
        fencefiles.load(content)
    except VesselsError:
        pass
