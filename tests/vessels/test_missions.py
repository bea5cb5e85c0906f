"""Mission checks and figures (vessels/missions.py): pure, no database."""

from __future__ import annotations

import pytest

from edge_client.contract import geo
from vessels import missions

FREMANTLE = (-32.0560, 115.7400)
# WGS84 geodesic lengths (Karney's GeographicLib): one degree along the equator is
# a·π/180; one degree of latitude from the equator is the meridian arc. the contract's geo uses a
# sphere, off by up to ~0.6 % against the ellipsoid.
EQUATOR_DEGREE_M = 111_319.49
MERIDIAN_DEGREE_M = 110_574.39
SPHERE_TOLERANCE = 0.006


def point(lat: float, lon: float, **extra: float | None) -> dict[str, float | None]:
    return {"lat": lat, "lon": lon, **extra}


def route(*metres_east: float) -> list[dict[str, float | None]]:
    """Points along a line east from Fremantle, at these distances."""
    return [point(*geo.offset(*FREMANTLE, 90, m)) for m in metres_east]


def test_leg_lengths_agree_with_the_geodesic_within_the_spheres_error() -> None:
    legs = missions.legs([point(0, 0), point(0, 1), point(1, 1)])
    assert legs[0].distance_m == pytest.approx(EQUATOR_DEGREE_M, rel=SPHERE_TOLERANCE)
    assert legs[1].distance_m == pytest.approx(MERIDIAN_DEGREE_M, rel=SPHERE_TOLERANCE)
    assert (legs[0].bearing_deg, legs[1].bearing_deg) == (pytest.approx(90), pytest.approx(0))


def test_a_route_has_one_leg_between_each_pair_of_items_with_times_at_cruise_speed() -> None:
    plan = missions.summary(route(0, 300, 900), cruise_speed_mps=1.5)
    assert [(leg.start, leg.to) for leg in plan.legs] == [(1, 2), (2, 3)]
    assert [round(leg.distance_m) for leg in plan.legs] == [300, 600]
    assert plan.total_m == pytest.approx(900, abs=1)
    assert plan.total_s == pytest.approx(600, abs=1)


def test_a_speed_change_applies_to_the_leg_to_its_item_and_every_leg_after() -> None:
    items = route(0, 300, 900, 1200)
    items[1]["speed_mps"] = 3.0
    legs = missions.legs(items, cruise_speed_mps=1.5)
    assert [leg.speed_mps for leg in legs] == [3.0, 3.0, 3.0]
    assert legs[0].time_s == pytest.approx(100, abs=0.5)


def test_holds_add_to_the_total_time() -> None:
    items = route(0, 150)
    items[0]["hold_s"], items[1]["hold_s"] = 60, 30
    plan = missions.summary(items, cruise_speed_mps=1.5)
    assert (plan.hold_s, plan.total_s) == (90, pytest.approx(190, abs=0.5))


def test_a_loop_counts_its_closing_leg_once_per_lap() -> None:
    plan = missions.summary(route(0, 500), end="loop", cruise_speed_mps=1.0)
    assert [(leg.start, leg.to) for leg in plan.legs] == [(1, 2), (2, 1)]
    assert plan.total_m == pytest.approx(1000, abs=1)


def test_a_return_home_sails_a_last_leg_to_the_planned_home() -> None:
    home = geo.offset(*FREMANTLE, 270, 200)
    plan = missions.summary(route(0, 500), end="return_home", home=home)
    assert plan.legs[-1].to == "home"
    assert plan.legs[-1].distance_m == pytest.approx(700, abs=1)
    # Without a planned home the return leg is unknown, and not guessed.
    assert [leg.to for leg in missions.legs(route(0, 500), end="return_home")] == [2]


def test_the_summary_is_json_ready_with_from_and_to() -> None:
    data = missions.summary(route(0, 100)).as_dict()
    assert data["legs"][0]["from"] == 1 and data["legs"][0]["to"] == 2
    assert set(data) == {"legs", "total_m", "hold_s", "total_s"}


def test_a_good_route_has_no_problems() -> None:
    assert missions.problems(route(0, 300, 900), max_leg_m=1000) == []


def test_an_empty_mission_is_refused() -> None:
    assert missions.problems([], max_leg_m=1000) == ["a mission needs at least one waypoint"]


def test_two_consecutive_identical_points_are_named() -> None:
    items = route(0, 300, 300, 600)
    assert missions.problems(items, max_leg_m=1000) == [
        f"waypoints 2 and 3 are the same point ({items[2]['lat']:.7f}, {items[2]['lon']:.7f})"
    ]


def test_points_equal_at_mavlink_precision_are_the_same_point() -> None:
    # MISSION_ITEM_INT carries 1e-7 degrees; a difference below that cannot reach the boat.
    a, b = point(-32.0, 115.0), point(-32.0 + 2e-9, 115.0)
    assert missions.problems([a, b], max_leg_m=1000) != []


def test_a_leg_over_the_limit_is_named_with_both_lengths() -> None:
    found = missions.problems(route(0, 300, 5300), max_leg_m=2000)
    assert found == ["leg 2 → 3 is 5.0 km, longer than the limit of 2.0 km (MISSION_MAX_LEG_M)"]


def test_a_loops_closing_leg_is_checked_too() -> None:
    items = route(0, 1500, 3000)
    assert missions.problems(items, max_leg_m=2000) == []
    assert missions.problems(items, max_leg_m=2000, end="loop") == [
        "leg 3 → 1 is 3.0 km, longer than the limit of 2.0 km (MISSION_MAX_LEG_M)"
    ]


def test_every_problem_is_reported_at_once() -> None:
    assert len(missions.problems(route(0, 0, 9000), max_leg_m=2000)) == 2


def test_a_cruise_speed_of_zero_is_refused() -> None:
    with pytest.raises(ValueError, match="cruise speed"):
        missions.legs(route(0, 100), cruise_speed_mps=0)


def test_durations_and_distances_read_well() -> None:
    assert missions.format_duration(3 * 3600 + 7 * 60) == "3 h 07 min"
    assert missions.format_duration(125) == "2 min"
    assert (missions.format_distance(950), missions.format_distance(12_345)) == (
        "950 m",
        "12.3 km",
    )


# --- the one review every display shows (issue 16 §4, §11) ---


def test_a_hold_under_a_minute_is_shown_in_seconds_and_totals_are_worded_once() -> None:
    items = route(0, 1095)
    items[1]["hold_s"] = 30
    review = missions.review(items, cruise_speed_mps=1.5)
    assert missions.format_duration(30) == "30 s"
    assert review["holds"] == ["", "30 s"]
    # 1095 m at 1.5 m/s is 730 s, plus a 30 s hold: 12.7 min, shown once, as 13 min.
    assert review["total"] == "2 waypoints · 1.1 km · 13 min (holds 30 s)"


def test_the_review_flags_an_over_long_leg_and_a_row_out_of_range() -> None:
    items = [*route(0, 113_000), point(95, 115.0), *route(113_500)]
    review = missions.review(items, max_leg_m=50_000)
    assert review["rows"][2] == ["latitude 95 is not within -90…90"]
    assert [row for n, row in enumerate(review["rows"]) if n != 2] == [[], [], []]
    # The bad row is left out of the route; the long leg is marked, the short one is not.
    assert [(leg["from"], leg["to"]) for leg in review["legs"]] == [(1, 2), (2, 3)]
    assert "longer than the limit of 50.0 km" in review["legs"][0]["problem"]
    assert review["legs"][1]["problem"] is None
    assert review["waypoints"] == 3
    assert review["problems"] == [
        review["legs"][0]["problem"],
        "row 3: latitude 95 is not within -90…90",
    ]


def test_the_review_and_the_send_checks_are_one_rule_set() -> None:
    items = route(0, 60_000, 60_000)
    review = missions.review(items, max_leg_m=50_000)
    assert review["problems"] == missions.problems(items, max_leg_m=50_000)


def test_a_confirmed_route_matches_only_the_saved_one() -> None:
    saved = route(0, 300, 900)
    shown = {"end": "stop", "items": [dict(i, hold_s=0) for i in saved]}
    assert missions.mismatch(saved, "stop", shown=shown) is None
    assert missions.mismatch(saved, "stop", shown={"end": "stop", "items": shown["items"][:2]}) == (
        "2 waypoints on screen, 3 saved"
    )
    moved = [dict(i) for i in shown["items"]]
    moved[1]["lat"] += 1e-6
    assert missions.mismatch(saved, "stop", shown={"end": "stop", "items": moved}) == (
        "waypoint 2 on screen is not waypoint 2 as saved"
    )
    assert missions.mismatch(saved, "loop", shown=shown) == "the end on screen is stop, saved loop"
    assert missions.mismatch(saved, "stop", shown=None) == "the route on screen was not confirmed"


def test_the_send_confirmation_sums_up_the_route_and_the_distance_from_the_boat() -> None:
    items = route(300, 1200)
    review = missions.review(items, cruise_speed_mps=1.5)
    text = missions.send_confirmation(
        review, items=items, end="return_home", vessel_name="SPAB", last_fix=FREMANTLE
    )
    assert text == (
        "Send to SPAB: 2 waypoints · 900 m · 10 min. SPAB's last fix is 300 m from waypoint 1; "
        "then it returns home."
    )


def test_the_send_confirmation_of_no_waypoints_says_so_not_that_the_boat_has_no_fix() -> None:
    review = missions.review([], cruise_speed_mps=1.5)
    text = missions.send_confirmation(
        review, items=[], end="stop", vessel_name="SPAB", last_fix=FREMANTLE
    )
    assert "it has no waypoints" in text and "no position" not in text
    no_fix = missions.send_confirmation(
        review, items=route(300), end="stop", vessel_name="SPAB", last_fix=None
    )
    assert "SPAB has no position yet" in no_fix
