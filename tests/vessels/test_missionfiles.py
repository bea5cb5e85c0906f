"""Mission files (vessels/missionfiles/): QGroundControl .plan, Mission Planner .waypoints and
GeoJSON, read and written. Pure: no database."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vessels import missionfiles
from vessels.errors import MissionFileError
from vessels.missionfiles import Item, MissionFile, mavitems

FILES = Path(__file__).parent / "files"
HOME = (-31.9852, 115.8327)


def read(name: str, **kwargs: object) -> MissionFile:
    return missionfiles.load((FILES / name).read_bytes(), filename=name, **kwargs)


def problems(content: str | bytes, **kwargs: object) -> list[str]:
    with pytest.raises(MissionFileError) as caught:
        missionfiles.load(content, **kwargs)
    return caught.value.problems


def plan_with(*items: dict[str, object], home: list[float] | None = None) -> str:
    return json.dumps(
        {
            "fileType": "Plan",
            "version": 1,
            "mission": {"items": list(items), "plannedHomePosition": home or [*HOME, 0]},
        }
    )


def simple(command: int, params: list[float | None], *, frame: int = 3, jump: int = 1) -> dict:
    return {
        "type": "SimpleItem",
        "command": command,
        "frame": frame,
        "params": params,
        "doJumpId": jump,
        "autoContinue": True,
    }


def waypoint(lat: float, lon: float, jump: int = 1, hold: float = 0) -> dict:
    return simple(16, [hold, 0, 0, None, lat, lon, 0], jump=jump)


# --- QGroundControl .plan ---


def test_a_plan_with_a_survey_is_refused_naming_the_survey_item() -> None:
    found = problems((FILES / "survey.plan").read_bytes(), filename="survey.plan")
    assert found[0] == "item 4 (ComplexItem survey): a Shoreside mission holds simple items only"
    assert found[-1] == "to import the rest, import again skipping unsupported items"


def test_a_plan_with_a_survey_imports_the_rest_when_asked_and_lists_the_survey() -> None:
    mission = read("survey.plan", skip_unsupported=True)
    assert mission.items == (
        Item(-31.98412, 115.83095),
        Item(-31.98201, 115.82744, hold_s=30, radius_m=5, speed_mps=2.5),
        Item(-31.977, 115.8301, hold_s=60),  # NAV_LOITER_TIME: its time is the hold
    )
    assert (mission.end, mission.home) == ("return_home", HOME)
    assert mission.skipped == (
        "item 4 (ComplexItem survey): a Shoreside mission holds simple items only",
    )


def test_a_jump_back_to_the_first_item_for_ever_is_a_loop() -> None:
    jump = simple(177, [1, -1, 0, 0, 0, 0, 0], frame=2, jump=3)
    mission = missionfiles.load(
        plan_with(waypoint(-32, 115, 1), waypoint(-32.01, 115, 2), jump), format="plan"
    )
    assert mission.end == "loop"


def test_a_jump_is_resolved_by_do_jump_id_not_by_position() -> None:
    # QGC numbers doJumpId itself; a file whose first item is id 7 loops back to 7.
    jump = simple(177, [7, -1, 0, 0, 0, 0, 0], frame=2, jump=9)
    mission = missionfiles.load(
        plan_with(waypoint(-32, 115, 7), waypoint(-32.01, 115, 8), jump), format="plan"
    )
    assert mission.end == "loop"


def test_every_unsupported_item_is_named_by_number_and_mav_cmd_name() -> None:
    found = problems(
        plan_with(
            simple(22, [0, 0, 0, None, -32, 115, 10], jump=1),  # takeoff
            waypoint(-32.0, 115.01, 2),
            simple(206, [25, 0, 1, 0, 0, 0, 0], frame=2, jump=3),  # camera trigger distance
            simple(16, [0, 0, 0, None, -32.01, 115.0, 0], frame=10, jump=4),  # terrain frame
            simple(16, [0, 0, 0, None, 10, 20, 0], frame=1, jump=5),  # local NED
            simple(31337, [0] * 7, frame=2, jump=6),
            simple(177, [2, -1, 0, 0, 0, 0, 0], frame=2, jump=7),  # jump into the middle
            waypoint(-32.02, 115.0, 8),
        ),
        format="plan",
    )
    assert found == [
        "item 1 (MAV_CMD_NAV_TAKEOFF): takeoff, landing and altitude commands are for aircraft",
        "item 3 (MAV_CMD_DO_SET_CAM_TRIGG_DIST): camera and gimbal actions are not part of a "
        "Shoreside mission",
        "item 4 (MAV_CMD_NAV_WAYPOINT): altitude above terrain (MAV_FRAME_GLOBAL_TERRAIN_ALT) "
        "means nothing to a boat",
        "item 5 (MAV_CMD_NAV_WAYPOINT): MAV_FRAME_LOCAL_NED is not a latitude/longitude frame "
        "a boat can use",
        "item 6 (MAV_CMD 31337): a Shoreside mission holds waypoints, holds, speed changes, a "
        "loop or a return home",
        "item 7 (MAV_CMD_DO_JUMP): a jump is supported only as the last item, back to the "
        "first (a loop)",
        "to import the rest, import again skipping unsupported items",
    ]


def test_a_jump_into_the_middle_or_a_finite_repeat_is_not_a_loop() -> None:
    middle = simple(177, [2, -1, 0, 0, 0, 0, 0], frame=2, jump=3)
    twice = simple(177, [1, 2, 0, 0, 0, 0, 0], frame=2, jump=3)
    route = (waypoint(-32, 115, 1), waypoint(-32.01, 115, 2))
    assert "a jump to item 2" in problems(plan_with(*route, middle), format="plan")[0]
    assert "repeats 2 times" in problems(plan_with(*route, twice), format="plan")[0]


def test_a_return_home_before_the_end_and_a_trailing_speed_change_are_unsupported() -> None:
    found = problems(
        plan_with(
            waypoint(-32, 115, 1),
            simple(20, [0] * 7, frame=2, jump=2),
            waypoint(-32.01, 115, 3),
            simple(178, [1, 2, -1, 0, 0, 0, 0], frame=2, jump=4),
        ),
        format="plan",
    )
    assert found[:2] == [
        "item 2 (MAV_CMD_NAV_RETURN_TO_LAUNCH): a return home is supported only as the last item",
        "item 4 (MAV_CMD_DO_CHANGE_SPEED): a speed change after the last waypoint",
    ]


def test_skipping_unsupported_items_lists_each_one() -> None:
    mission = missionfiles.load(
        plan_with(
            simple(22, [0, 0, 0, None, -32, 115, 10], jump=1),
            waypoint(-32.0, 115.01, 2),
            simple(203, [0] * 7, frame=2, jump=3),
        ),
        format="plan",
        skip_unsupported=True,
    )
    assert mission.items == (Item(-32.0, 115.01),)
    assert [s.split(":")[0] for s in mission.skipped] == [
        "item 1 (MAV_CMD_NAV_TAKEOFF)",
        "item 3 (MAV_CMD_DO_DIGICAM_CONTROL)",
    ]


def test_a_file_with_nothing_to_sail_to_is_refused_even_when_skipping() -> None:
    only_takeoff = plan_with(simple(22, [0, 0, 0, None, -32, 115, 10]))
    assert problems(only_takeoff, format="plan", skip_unsupported=True) == [
        "the file has no waypoints a boat can sail to"
    ]


def test_an_exported_plan_is_what_qgroundcontrol_expects() -> None:
    mission = MissionFile(
        items=(Item(-32.0, 115.0, hold_s=10, radius_m=3), Item(-32.01, 115.0, speed_mps=2.0)),
        end="loop",
        home=HOME,
    )
    plan = json.loads(missionfiles.dump(mission, "plan", cruise_speed_mps=1.8).content)
    assert (plan["fileType"], plan["version"], plan["groundStation"]) == ("Plan", 1, "Shoreside")
    assert plan["geoFence"] == {"version": 2, "circles": [], "polygons": []}
    assert plan["rallyPoints"] == {"version": 2, "points": []}
    body = plan["mission"]
    assert (body["version"], body["firmwareType"], body["vehicleType"]) == (2, 3, 11)
    assert (body["cruiseSpeed"], body["hoverSpeed"]) == (1.8, 1.8)
    assert body["plannedHomePosition"] == [*HOME, 0]
    assert [(i["command"], i["frame"], i["doJumpId"]) for i in body["items"]] == [
        (16, 3, 1),
        (178, 2, 2),
        (16, 3, 3),
        (177, 2, 4),
    ]
    assert body["items"][0]["params"] == [10, 3, 0, None, -32.0, 115.0, 0]
    assert body["items"][1]["params"] == [1, 2.0, -1, 0, 0, 0, 0]
    assert body["items"][3]["params"] == [1, -1, 0, 0, 0, 0, 0]
    assert all(len(i["params"]) == 7 and i["autoContinue"] for i in body["items"])
    assert body["items"][0]["AltitudeMode"] == 1 and "AltitudeMode" not in body["items"][1]


# --- Mission Planner .waypoints ---


def test_a_waypoints_file_keeps_home_apart_and_speed_changes_on_their_waypoints() -> None:
    mission = read("matilda-bay.waypoints")
    assert mission.home == HOME
    assert mission.items == (
        Item(-31.98412, 115.83095, radius_m=3, speed_mps=1.8),
        Item(-31.98201, 115.82744, hold_s=20),
        Item(-31.98015, 115.82511, speed_mps=3.0),
    )
    assert (mission.end, mission.skipped) == ("loop", ())


def test_a_waypoints_file_reads_the_same_with_lf_line_ends() -> None:
    crlf = (FILES / "matilda-bay.waypoints").read_bytes()
    assert b"\r\n" in crlf
    lf = crlf.replace(b"\r\n", b"\n")
    assert missionfiles.load(lf, format="waypoints") == read("matilda-bay.waypoints")


def test_a_waypoints_file_names_unsupported_rows_by_their_index() -> None:
    text = (
        "QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t-31.9\t115.8\t0\t1\n"
        "1\t0\t3\t22\t0\t0\t0\t0\t-31.9\t115.8\t10\t1\n"
        "2\t0\t3\t16\t0\t0\t0\t0\t-31.91\t115.8\t0\t1\n"
        "3\t0\t3\t21\t0\t0\t0\t0\t-31.92\t115.8\t0\t1\n"
    )
    assert problems(text, format="waypoints")[:2] == [
        "item 1 (MAV_CMD_NAV_TAKEOFF): takeoff, landing and altitude commands are for aircraft",
        "item 3 (MAV_CMD_NAV_LAND): takeoff, landing and altitude commands are for aircraft",
    ]


def test_an_exported_waypoints_file_is_tab_separated_with_a_home_row() -> None:
    mission = MissionFile(items=(Item(-32.0, 115.0, speed_mps=2.5),), end="return_home", home=HOME)
    text = missionfiles.dump(mission, "waypoints", cruise_speed_mps=1.5).content
    lines = text.split("\r\n")
    assert lines[0] == "QGC WPL 110" and lines[-1] == ""
    rows = [line.split("\t") for line in lines[1:-1]]
    assert all(len(row) == 12 for row in rows)
    assert [(r[0], r[3]) for r in rows] == [("0", "16"), ("1", "178"), ("2", "16"), ("3", "20")]
    assert (float(rows[0][8]), float(rows[0][9])) == HOME


# --- GeoJSON ---


def test_geojson_points_carry_their_properties_and_are_ordered_by_seq() -> None:
    mission = read("stations.geojson")
    assert mission.items == (
        Item(-31.98412, 115.83095, speed_mps=2.0),
        Item(-31.98201, 115.82744, hold_s=120, radius_m=4),
        Item(-31.98015, 115.82511, hold_s=300),
    )
    assert (mission.name, mission.end, mission.home) == ("Sampling stations", "return_home", HOME)


def test_a_geojson_linestring_is_a_route_of_plain_waypoints() -> None:
    mission = read("route-line.geojson")
    assert [(i.lat, i.lon) for i in mission.items] == [
        (-31.98412, 115.83095),
        (-31.98201, 115.82744),
        (-31.98015, 115.82511),
    ]
    assert (mission.name, mission.end, mission.home) == ("Swan River transect", "stop", None)


def test_a_geojson_polygon_is_unsupported_and_named() -> None:
    polygon = {
        "type": "Feature",
        "geometry": {"type": "Polygon", "coordinates": [[[115, -32], [115.1, -32], [115, -32]]]},
    }
    line = {"type": "Feature", "geometry": {"type": "LineString", "coordinates": [[115, -32]]}}
    text = json.dumps({"type": "FeatureCollection", "features": [line, polygon]})
    assert problems(text, format="geojson")[0] == (
        "feature 2 (Polygon): a mission is Points or one LineString"
    )
    assert missionfiles.load(text, format="geojson", skip_unsupported=True).items == (
        Item(-32, 115),
    )


# --- garbage in: clear errors, never another exception ---


@pytest.mark.parametrize(
    ("content", "fmt", "message"),
    [
        (b"\xff\xfe\x00junk", "plan", "the file is not UTF-8 text"),
        ("{not json", "plan", "not a QGroundControl plan file: invalid JSON"),
        ('{"fileType": "Fence"}', "plan", 'not a QGroundControl plan: no "fileType": "Plan"'),
        ("[" * 100_000, "geojson", "nested too deeply"),
        ("QGC WPL 110\n1\t0\t3\t16\n", "waypoints", "line 2: 4 fields; a waypoint line has 12"),
        ("WPL 110\n", "waypoints", 'no "QGC WPL 110" header'),
        (
            "QGC WPL 110\n1\t0\t3\t16\t0\t0\t0\t0\tnan\t115\t0\t1\n",
            "waypoints",
            "item 1 (MAV_CMD_NAV_WAYPOINT): latitude and longitude must be numbers",
        ),
        (
            "QGC WPL 110\n1\t0\t3\t16\t0\t0\t0\t0\t95\t115\t0\t1\n",
            "waypoints",
            "position 95.0, 115.0 is outside -90…90 latitude",
        ),
        (
            "QGC WPL 110\n1\t0\t3\tsixteen\t0\t0\t0\t0\t-32\t115\t0\t1\n",
            "waypoints",
            "must be whole numbers",
        ),
        ('{"type": "Point", "coordinates": [200, 10]}', "geojson", "outside -90…90"),
        (plan_with(waypoint(-32, 115), home=[None, 3]), "plan", "plannedHomePosition"),
        (
            plan_with(simple(16, [0, 0, 0, None, -32, "115", 0])),
            "plan",
            "params must be numbers or null",
        ),
    ],
)
def test_garbage_is_a_clear_error(content: str | bytes, fmt: str, message: str) -> None:
    assert message in " | ".join(problems(content, format=fmt))


def test_an_unknown_format_or_extension_is_a_clear_error() -> None:
    assert (
        "cannot tell the format of notes.docx" in problems(b"PK\x03\x04", filename="notes.docx")[0]
    )
    assert "unknown format 'kml'" in problems(b"", format="kml")[0]


def test_the_format_is_told_by_extension_then_by_content() -> None:
    plan = (FILES / "survey.plan").read_bytes()
    assert missionfiles.detect(filename="a.plan") == "plan"
    assert missionfiles.detect(filename="a.json", content=plan) == "plan"
    assert missionfiles.detect(filename="a.txt") == "waypoints"
    assert missionfiles.detect(content=b"QGC WPL 110\r\n") == "waypoints"
    assert missionfiles.detect(content=b'{"type": "FeatureCollection"}') == "geojson"


@settings(max_examples=150, deadline=None)
@given(content=st.binary(max_size=300), fmt=st.sampled_from(missionfiles.FORMATS))
def test_random_bytes_never_raise_anything_but_a_mission_file_error(
    content: bytes, fmt: str
) -> None:
    try:
        missionfiles.load(content, format=fmt)
    except MissionFileError:
        pass


_json = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=8) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=10,
)
_keys = st.sampled_from(
    ["type", "command", "frame", "params", "doJumpId", "complexItemType", "coordinates"]
)


@settings(max_examples=60, deadline=None)
@given(
    items=st.lists(st.dictionaries(_keys, _json, max_size=6), max_size=5),
    home=_json,
    fmt=st.sampled_from(["plan", "geojson"]),
)
def test_random_json_shaped_like_a_mission_never_raises_anything_else(
    items: list[dict], home: object, fmt: str
) -> None:
    if fmt == "plan":
        doc = {"fileType": "Plan", "mission": {"items": items, "plannedHomePosition": home}}
    else:
        doc = {
            "type": "FeatureCollection",
            "properties": home,
            "features": [{"type": "Feature", "geometry": i} for i in items],
        }
    try:
        missionfiles.load(json.dumps(doc), format=fmt)
    except MissionFileError:
        pass


_field = st.one_of(
    st.sampled_from(["0", "1", "16", "177", "178", "-1", "nan", "inf", "1e400", "x", ""]),
    st.floats(allow_nan=True).map(repr),
)


@settings(max_examples=100, deadline=None)
@given(rows=st.lists(st.lists(_field, min_size=10, max_size=13), max_size=5))
def test_random_waypoint_rows_never_raise_anything_else(rows: list[list[str]]) -> None:
    text = "QGC WPL 110\n" + "\n".join("\t".join(row) for row in rows)
    try:
        missionfiles.load(text, format="waypoints")
    except MissionFileError:
        pass


# --- round trips ---

_lat = st.floats(-89.9, 89.9, allow_nan=False)
_lon = st.floats(-179.9, 179.9, allow_nan=False)
_items = st.lists(
    st.builds(
        Item,
        lat=_lat,
        lon=_lon,
        hold_s=st.sampled_from([0.0, 5.0, 60.0, 1234.5]),
        radius_m=st.none() | st.floats(0.5, 1000),
        speed_mps=st.none() | st.floats(0.1, 20),
    ),
    min_size=1,
    max_size=12,
)
_missions = st.builds(
    MissionFile,
    items=_items.map(tuple),
    end=st.sampled_from(["stop", "loop", "return_home"]),
    home=st.none() | st.tuples(_lat, _lon).filter(lambda h: h != (0.0, 0.0)),
    name=st.just("Survey"),
)


@settings(max_examples=100, deadline=None)
@given(mission=_missions, fmt=st.sampled_from(missionfiles.FORMATS))
def test_export_then_import_gives_the_same_items_end_and_home(
    mission: MissionFile, fmt: str
) -> None:
    exported = missionfiles.dump(mission, fmt, cruise_speed_mps=1.5)
    back = missionfiles.load(exported.content.encode(), format=fmt, name="Survey")
    assert back == mission


def test_every_named_command_reads_as_its_mav_cmd_name() -> None:
    assert mavitems.command_name(16) == "MAV_CMD_NAV_WAYPOINT"
    assert mavitems.command_name(12345) == "MAV_CMD 12345"
    assert math.isnan(mavitems.write(MissionFile(items=(Item(0.5, 0.5),)))[0].params[3])
