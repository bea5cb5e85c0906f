"""The simulator speaks the parts of ArduPilot Rover's MAVLink the client relies on."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from tests.edge_client.helpers import ROOT, wait_until  # noqa: E402

m = mavutil.mavlink


@pytest.fixture
def gcs(make_sim):
    """A raw pymavlink peer on a simulator, plus a helper to wait for one message type."""

    def connect(**options):
        sim = make_sim(**options)
        conn = mavutil.mavlink_connection(sim.endpoint, source_system=255, source_component=190)
        conn.mav.heartbeat_send(6, 8, 0, 0, 0)
        assert conn.recv_match(type="HEARTBEAT", blocking=True, timeout=5)

        def expect(*types: str, timeout: float = 3.0):
            msg = conn.recv_match(type=list(types), blocking=True, timeout=timeout)
            assert msg is not None, f"no {types}"
            return msg

        return sim.sim, conn, expect

    return connect


def test_upload_items_are_requested_with_the_old_mission_request_by_default(gcs):
    _, conn, expect = gcs()
    conn.mav.mission_count_send(1, 1, 2)
    assert expect("MISSION_REQUEST", "MISSION_REQUEST_INT").get_type() == "MISSION_REQUEST"


def test_mission_request_int_by_option(gcs):
    _, conn, expect = gcs(request_int=True)
    conn.mav.mission_count_send(1, 1, 2)
    assert expect("MISSION_REQUEST", "MISSION_REQUEST_INT").get_type() == "MISSION_REQUEST_INT"


def test_a_lost_item_is_requested_again(gcs):
    _, conn, expect = gcs()
    conn.mav.mission_count_send(1, 1, 2)
    first = expect("MISSION_REQUEST")
    again = expect("MISSION_REQUEST", timeout=2)  # we never answered: asked again
    assert first.seq == again.seq == 0


def test_the_last_item_sent_again_is_acked_again(gcs):
    _, conn, expect = gcs()
    conn.mav.mission_count_send(1, 1, 1)
    assert expect("MISSION_REQUEST").seq == 0
    item = (1, 1, 0, m.MAV_FRAME_GLOBAL, 16, 0, 1, 0, 0, 0, 0, -319800000, 1158200000, 0)
    conn.mav.mission_item_int_send(*item)
    assert expect("MISSION_ACK").type == m.MAV_MISSION_ACCEPTED
    conn.mav.mission_item_int_send(*item)  # as if that MISSION_ACK had been lost
    assert expect("MISSION_ACK").type == m.MAV_MISSION_ACCEPTED


def test_too_many_items_is_no_space(gcs):
    _, conn, expect = gcs(max_items=3)
    conn.mav.mission_count_send(1, 1, 10)
    assert expect("MISSION_ACK").type == m.MAV_MISSION_NO_SPACE


def test_an_unsupported_frame_is_refused(gcs):
    _, conn, expect = gcs()
    conn.mav.mission_count_send(1, 1, 1)
    expect("MISSION_REQUEST")
    conn.mav.mission_item_int_send(1, 1, 0, m.MAV_FRAME_BODY_NED, 16, 0, 1, 0, 0, 0, 0, 1, 1, 0)
    assert expect("MISSION_ACK").type == m.MAV_MISSION_UNSUPPORTED_FRAME


def test_download_starts_with_home(gcs):
    sim, conn, expect = gcs(lat=-31.5, lon=115.5)
    conn.mav.mission_request_list_send(1, 1)
    assert expect("MISSION_COUNT").count == 1
    conn.mav.mission_request_int_send(1, 1, 0)
    home = expect("MISSION_ITEM_INT")
    assert (home.seq, home.x, home.y) == (0, -315000000, 1155000000)
    # The old MISSION_REQUEST gets the old MISSION_ITEM: the same point, in float degrees.
    conn.mav.mission_request_send(1, 1, 0)
    old = expect("MISSION_ITEM")
    assert (old.seq, old.x, old.y) == (0, pytest.approx(-31.5), pytest.approx(115.5))


@pytest.mark.slow
def test_prearm_checks_pass_only_after_the_delay(gcs):
    sim, conn, expect = gcs(prearm_delay_s=1.5)
    conn.mav.command_long_send(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    assert "PreArm" in expect("STATUSTEXT").text  # the reason comes first, as from ArduPilot
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_FAILED
    # Wait on the simulator's own clock, not a sleep racing its deadline.
    wait_until(lambda: time.monotonic() - sim.boot >= sim.prearm_delay_s, 10, "pre-arm delay")
    conn.mav.command_long_send(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED
    assert sim.armed


NEVER = 1e9  # a position_delay_s the test lowers to 0 when it wants the EKF ready


def arm(conn, expect) -> None:
    conn.mav.command_long_send(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED


def set_mode(conn, number: int) -> None:
    conn.mav.command_long_send(1, 1, m.MAV_CMD_DO_SET_MODE, 0, 1, number, 0, 0, 0, 0, 0)


def wait_for(conn, kind: str, predicate, timeout: float = 5.0):
    """The first ``kind`` message for which ``predicate`` holds (a condition, not a delay)."""
    while (msg := conn.recv_match(type=kind, blocking=True, timeout=timeout)) is not None:
        if predicate(msg):
            return msg
    raise AssertionError(f"no {kind} matching the condition")


@pytest.mark.slow
def test_armed_before_the_ekf_has_a_position_modes_that_need_one_are_refused(gcs):
    sim, conn, expect = gcs(prearm_delay_s=0, position_delay_s=NEVER)
    starting = expect("EKF_STATUS_REPORT")
    assert starting.flags & m.EKF_CONST_POS_MODE and not starting.flags & m.EKF_POS_HORIZ_ABS
    assert expect("GPS_RAW_INT").fix_type < 3
    assert not expect("SYS_STATUS").onboard_control_sensors_health & m.MAV_SYS_STATUS_AHRS
    arm(conn, expect)
    set_mode(conn, 15)  # GUIDED
    assert expect("STATUSTEXT").text == "Flight mode change failed"  # as Rover::set_mode says
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_FAILED and sim.mode_name == "HOLD"
    set_mode(conn, 0)  # MANUAL needs no position
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED
    sim.position_delay_s = 0  # the EKF converges
    wait_for(conn, "EKF_STATUS_REPORT", lambda r: r.flags & m.EKF_POS_HORIZ_ABS
             and not r.flags & m.EKF_CONST_POS_MODE)  # fmt: skip
    wait_for(conn, "SYS_STATUS", lambda r: r.onboard_control_sensors_health & m.MAV_SYS_STATUS_AHRS)
    assert wait_for(conn, "GPS_RAW_INT", lambda r: True).fix_type == 3
    set_mode(conn, 15)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED and sim.mode_name == "GUIDED"


def test_disarmed_any_mode_is_taken_before_the_ekf_has_a_position(gcs):
    sim, conn, expect = gcs(position_delay_s=NEVER)  # Rover skips the check while disarmed
    set_mode(conn, 15)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED and sim.mode_name == "GUIDED"


def test_home_and_origin_are_sent_once_the_gps_has_a_fix(gcs):
    sim, conn, expect = gcs(position_delay_s=NEVER)
    conn.mav.command_long_send(1, 1, m.MAV_CMD_REQUEST_MESSAGE, 0, 242, 0, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_FAILED  # no home yet
    sim.position_delay_s = 0
    home = expect("HOME_POSITION")
    origin = expect("GPS_GLOBAL_ORIGIN")
    assert (home.latitude, origin.latitude) == (int(sim.home[0] * 1e7),) * 2


@pytest.mark.slow
def test_rtl_drives_home_says_so_and_stays_there(gcs):
    sim, conn, expect = gcs(prearm_delay_s=0)
    arm(conn, expect)
    set_mode(conn, 15)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED
    conn.mav.set_position_target_global_int_send(0, 1, 1, 6, 0b110111111000, -319790000,
                                                 1158205000, 0, 0, 0, 0, 0, 0, 0, 0, 0)  # fmt: skip
    wait_for(conn, "GLOBAL_POSITION_INT", lambda p: abs(p.lat - -319790000) <= 1)
    set_mode(conn, 11)  # RTL
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED
    wait_for(conn, "STATUSTEXT", lambda t: t.text == "Reached destination")
    assert sim.mode_name == "RTL"  # a boat loiters at home, it does not change mode
    at = wait_for(conn, "GLOBAL_POSITION_INT", lambda p: True)
    assert (at.lat, at.lon) == (int(sim.home[0] * 1e7), int(sim.home[1] * 1e7))


def test_refused_modes_are_denied(gcs):
    sim, conn, expect = gcs(refuse_modes=("RTL",))
    conn.mav.command_long_send(1, 1, m.MAV_CMD_DO_SET_MODE, 0, 1, 11, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_DENIED
    conn.mav.command_long_send(1, 1, m.MAV_CMD_DO_SET_MODE, 0, 1, 15, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED and sim.mode_name == "GUIDED"


@pytest.mark.parametrize(("mode", "number"), [("DOCK", 8), ("CIRCLE", 9)])
def test_every_rover_mode_can_be_entered(gcs, mode, number):
    sim, conn, expect = gcs()
    conn.mav.command_long_send(1, 1, m.MAV_CMD_DO_SET_MODE, 0, 1, number, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED and sim.mode_name == mode


def test_the_simulator_needs_only_pymavlink_and_the_standard_library():
    code = (
        "import sys, edge_client.sim, edge_client.sim.__main__;"
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'django', 'requests', 'serial',"
        " 'commands', 'vessels', 'telemetry', 'fleet', 'sms', 'tests'}))"
    )
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                            text=True, timeout=60)  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


def test_the_command_line_help_runs():
    result = subprocess.run([sys.executable, "-m", "edge_client.sim", "--help"], cwd=ROOT,
                            capture_output=True, text=True, timeout=60)  # fmt: skip
    assert result.returncode == 0 and "--reject-mission" in result.stdout
