"""The simulator speaks the parts of ArduPilot Rover's MAVLink the client relies on."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from tests.edge_client.helpers import ROOT  # noqa: E402

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


def test_prearm_checks_pass_only_after_the_delay(gcs):
    sim, conn, expect = gcs(prearm_delay_s=1.5)
    conn.mav.command_long_send(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    assert "PreArm" in expect("STATUSTEXT").text  # the reason comes first, as from ArduPilot
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_FAILED
    time.sleep(1.6)
    conn.mav.command_long_send(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED
    assert sim.armed


def test_refused_modes_are_denied(gcs):
    sim, conn, expect = gcs(refuse_modes=("RTL",))
    conn.mav.command_long_send(1, 1, m.MAV_CMD_DO_SET_MODE, 0, 1, 11, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_DENIED
    conn.mav.command_long_send(1, 1, m.MAV_CMD_DO_SET_MODE, 0, 1, 15, 0, 0, 0, 0, 0)
    assert expect("COMMAND_ACK").result == m.MAV_RESULT_ACCEPTED and sim.mode_name == "GUIDED"


def test_the_command_line_help_runs():
    result = subprocess.run([sys.executable, "-m", "tests.sim", "--help"], cwd=ROOT,
                            capture_output=True, text=True, timeout=60)  # fmt: skip
    assert result.returncode == 0 and "--reject-mission" in result.stdout
