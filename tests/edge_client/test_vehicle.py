"""VehicleState's judgement of the autopilot's position readiness, from its own reports."""

from __future__ import annotations

import time
from types import SimpleNamespace

import pytest

from edge_client.mission import WaypointNumbers, build_mission
from edge_client.vehicle import (
    EKF_CONST_POS_MODE,
    EKF_POS_HORIZ_ABS,
    EKF_POS_HORIZ_REL,
    MAV_SYS_STATUS_AHRS,
    MAV_SYS_STATUS_SENSOR_GPS,
    VehicleState,
)

SENSORS = MAV_SYS_STATUS_SENSOR_GPS | MAV_SYS_STATUS_AHRS


def sys_status(health: int) -> SimpleNamespace:
    return SimpleNamespace(voltage_battery=12600, onboard_control_sensors_present=SENSORS,
                           onboard_control_sensors_enabled=SENSORS,
                           onboard_control_sensors_health=health)  # fmt: skip


def test_nothing_heard_yet_is_unknown():
    ready, why = VehicleState().position_ready()
    assert ready is None and "no EKF" in why


@pytest.mark.parametrize(
    ("flags", "ready", "why"),
    [
        (1 | 2 | EKF_CONST_POS_MODE | EKF_POS_HORIZ_REL, False, "constant-position"),
        (1 | 2, False, "no horizontal position"),
        (1 | 2 | EKF_POS_HORIZ_ABS, True, "has a horizontal position"),
        (1 | 2 | EKF_POS_HORIZ_REL, True, "has a horizontal position"),
    ],
)
def test_the_ekf_flags_decide_as_rover_does_when_armed(flags, ready, why):
    state = VehicleState()
    state.on_gps_raw_int(SimpleNamespace(fix_type=3))
    state.on_ekf_status_report(SimpleNamespace(flags=flags))
    assert state.position_ready()[0] is ready and why in state.position_ready()[1]


def test_without_ekf_reports_gps_fix_health_and_origin_decide():
    state = VehicleState()
    state.on_gps_raw_int(SimpleNamespace(fix_type=1))
    assert state.position_ready() == (False, "no 3D GPS fix yet (GPS_RAW_INT fix_type 1)")
    state.on_gps_raw_int(SimpleNamespace(fix_type=3))
    state.on_sys_status(sys_status(MAV_SYS_STATUS_SENSOR_GPS))
    assert state.position_ready() == (False, "AHRS not healthy yet (SYS_STATUS)")
    state.on_sys_status(sys_status(SENSORS))
    assert state.position_ready() == (False, "no EKF origin or home yet")
    state.on_gps_global_origin(SimpleNamespace(latitude=-319800000, longitude=1158200000))
    assert state.position_ready()[0] is True and state.origin == (-31.98, 115.82)


def test_statustext_since_returns_only_what_came_after():
    state = VehicleState()
    state.on_statustext(SimpleNamespace(text="PreArm: Gyros inconsistent"))
    mark = state.statustext_count
    assert state.statustext_since(mark) == []
    state.on_statustext(SimpleNamespace(text=b"Flight mode change failed\x00"))
    assert state.statustext_since(mark) == ["Flight mode change failed"]


def test_a_fix_counts_waypoints_as_the_operator_does_once_our_mission_is_known():
    state = VehicleState()
    state.lat, state.lon, state.position_at = -31.9, 115.8, time.monotonic()
    state.mission_seq = 4  # home, speed, wp1, wp2, speed (leading to wp3)
    assert "waypoint" not in state.fix(wall_now=1.8e9)["readings"]  # not our mission's numbers
    wps = [{"lat": -31.9, "lon": 115.8, "speed_mps": 2.0 if i in (0, 2) else None}
           for i in range(5)]  # fmt: skip
    state.waypoints = WaypointNumbers.of(build_mission((-31.9, 115.8), wps))
    readings = state.fix(wall_now=1.8e9)["readings"]
    assert (readings["mission_item"], readings["waypoint"], readings["waypoints"]) == (4, 3, 5)
