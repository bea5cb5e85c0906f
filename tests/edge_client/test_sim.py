"""The simulator speaks the parts of ArduPilot Rover's MAVLink the client relies on."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
from dataclasses import replace

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from edge_client.contract.geo import distance_m, offset  # noqa: E402
from edge_client.mission import MAV_CMD_NAV_LOITER_TIME, MissionItem, build_mission  # noqa: E402
from edge_client.sim.rover import Item, RoverSim  # noqa: E402
from tests.edge_client.conftest import free_port  # noqa: E402
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


def mode_answer(conn) -> tuple[list[str], int]:
    """The STATUSTEXTs up to the next COMMAND_ACK, and its result."""
    texts = []
    while (msg := conn.recv_match(type=["STATUSTEXT", "COMMAND_ACK"], blocking=True,
                                  timeout=3)) is not None:  # fmt: skip
        if msg.get_type() == "COMMAND_ACK":
            return texts, msg.result
        texts.append(msg.text)
    raise AssertionError("no COMMAND_ACK")


@pytest.mark.slow
def test_armed_before_the_ekf_has_a_position_modes_that_need_one_are_refused(gcs):
    sim, conn, expect = gcs(prearm_delay_s=0, position_delay_s=NEVER, ekf_failsafe_s=0)
    starting = expect("EKF_STATUS_REPORT")
    assert starting.flags & m.EKF_CONST_POS_MODE and not starting.flags & m.EKF_POS_HORIZ_ABS
    assert expect("GPS_RAW_INT").fix_type < 3
    assert not expect("SYS_STATUS").onboard_control_sensors_health & m.MAV_SYS_STATUS_AHRS
    arm(conn, expect)
    set_mode(conn, 15)  # GUIDED
    texts, result = mode_answer(conn)
    assert "Flight mode change failed" in texts  # as Rover::set_mode says
    assert result == m.MAV_RESULT_FAILED and sim.mode_name == "HOLD"
    set_mode(conn, 0)  # MANUAL needs no position
    assert mode_answer(conn)[1] == m.MAV_RESULT_ACCEPTED
    sim.position_delay_s = 0  # the EKF converges
    wait_for(conn, "EKF_STATUS_REPORT", lambda r: r.flags & m.EKF_POS_HORIZ_ABS
             and not r.flags & m.EKF_CONST_POS_MODE)  # fmt: skip
    wait_for(conn, "SYS_STATUS", lambda r: r.onboard_control_sensors_health & m.MAV_SYS_STATUS_AHRS)
    assert wait_for(conn, "GPS_RAW_INT", lambda r: True).fix_type == 3
    wait_until(lambda: not sim.ekf_failsafe, 5, "the EKF failsafe to clear")
    set_mode(conn, 15)
    assert mode_answer(conn)[1] == m.MAV_RESULT_ACCEPTED and sim.mode_name == "GUIDED"


@pytest.mark.slow
def test_start_up_order_is_rovers_position_first_then_the_ekf_failsafe_clears(gcs):
    """Armed through start-up, as on a real Rover: "EKF failsafe" after a second without a
    position; the position comes, modes that need one are still refused; "EKF failsafe
    cleared" ``ekf_failsafe_s`` later, and only then are they taken."""
    sim, conn, expect = gcs(prearm_delay_s=0, position_delay_s=NEVER, ekf_failsafe_s=1.5)
    arm(conn, expect)
    wait_for(conn, "STATUSTEXT", lambda t: t.text == "EKF failsafe", timeout=5)
    assert sim.ekf_failsafe
    sim.position_delay_s = 0  # the EKF converges
    wait_for(conn, "STATUSTEXT", lambda t: t.text == "EKF3 IMU0 is using GPS")
    position_at = time.monotonic()
    set_mode(conn, 15)  # GUIDED, with a position but the failsafe not yet cleared
    texts, result = mode_answer(conn)
    assert result == m.MAV_RESULT_FAILED and "Flight mode change failed" in texts
    assert sim.mode_name == "HOLD"
    wait_for(conn, "STATUSTEXT", lambda t: t.text == "EKF failsafe cleared")
    assert 1.0 <= time.monotonic() - position_at < 3.0
    set_mode(conn, 10)  # AUTO: refused for want of a mission now, not of a position
    assert mode_answer(conn) == (["AutoMode: no mission"], m.MAV_RESULT_FAILED)
    set_mode(conn, 15)
    assert mode_answer(conn)[1] == m.MAV_RESULT_ACCEPTED and sim.mode_name == "GUIDED"


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
    # Rover says so within WP_RADIUS: the boat may still be closing the last metres.
    home = (int(sim.home[0] * 1e7), int(sim.home[1] * 1e7))
    wait_for(conn, "GLOBAL_POSITION_INT", lambda p: (p.lat, p.lon) == home)
    at = wait_for(conn, "GLOBAL_POSITION_INT", lambda p: True)
    assert (at.lat, at.lon) == home and sim.mode_name == "RTL"


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


# -- missions, run as Rover runs them, on the simulator's own clock --------------------------------


HOME = (-31.98, 115.82)
DT = 0.02  # simulated seconds per step


def wp(item: MissionItem) -> Item:
    """The edge client's MISSION_ITEM_INT as the simulator's Item (what an upload delivers)."""
    return Item(item.seq, item.frame, item.command, 0, item.autocontinue, item.param1,
                item.param2, item.param3, item.param4, item.x, item.y, item.z)  # fmt: skip


def north(metres: float, of: tuple[float, float] = HOME) -> dict:
    lat, lon = offset(*of, 0.0, metres)
    return {"lat": lat, "lon": lon, "hold_s": 0, "radius_m": None, "speed_mps": None}


class Driven:
    """A simulator the test steps on a clock of its own: simulated seconds pass at once.

    Arming and mode changes go over real MAVLink from a GCS connection; the mission is loaded
    as an accepted upload leaves it (the upload itself is tested over the link below).
    """

    def __init__(self, **options) -> None:
        port = free_port()
        options = {"lat": HOME[0], "lon": HOME[1], "speed_mps": 20.0, "prearm_delay_s": 0,
                   **options}  # fmt: skip
        self.sim = RoverSim([f"udpin:127.0.0.1:{port}"], **options)
        self.gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255,
                                              source_component=190)  # fmt: skip
        self.now = time.monotonic()
        self.heard: list = []

    def close(self) -> None:
        self.gcs.close()
        self.sim.close()

    def step(self) -> None:
        self.now += DT
        self.sim.step(self.now)
        while (msg := self.gcs.recv_msg()) is not None:
            self.heard.append(msg)

    def until(self, condition, limit_s: float = 120.0) -> float:
        """Step until ``condition()``; returns the simulated time it took."""
        start = self.now
        while not condition():
            assert self.now - start < limit_s, "the simulator never got there"
            self.step()
        return self.now - start

    def _settle(self, condition) -> None:
        # A message sent over UDP arrives a moment later in real time: step until it is handled.
        deadline = time.monotonic() + 5
        while not condition():
            assert time.monotonic() < deadline, "the simulator did not take the command"
            self.step()
            time.sleep(0.001)

    def start(self, items: list[MissionItem] | None = None) -> None:
        """Arm, then AUTO: with ``items`` loaded first, or the mission already loaded."""
        if items is not None:
            self.sim.load_mission([wp(i) for i in items])
        self.gcs.mav.command_long_send(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0,
                                       0, 0)  # fmt: skip
        self._settle(lambda: self.sim.armed)
        set_mode(self.gcs, 10)  # AUTO
        self._settle(lambda: self.sim.mode_name == "AUTO")

    def times(self, kind: str, seq: int) -> list[float]:
        return [e.t for e in self.sim.events if e.kind == kind and e.seq == seq]

    def texts(self) -> list[str]:
        return [msg.text for msg in self.heard if msg.get_type() == "STATUSTEXT"]


@pytest.fixture
def driven():
    made: list[Driven] = []

    def make(**options) -> Driven:
        made.append(Driven(**options))
        return made[-1]

    yield make
    for d in made:
        d.close()


def test_a_speed_change_sets_the_speed_from_its_waypoints_leg_on(driven):
    d = driven(speed_mps=20.0)
    first, second = north(100), north(200)
    third = north(260)
    m = build_mission(HOME, [first, {**second, "speed_mps": 5.0}, third])
    d.start(m)  # home, WP 1, DO_CHANGE_SPEED 2, WP 3, WP 4
    d.until(lambda: d.sim.current == 1 and d.sim.arrived_at is None and d.sim.vn > 0)
    assert math.hypot(d.sim.vn, d.sim.ve) == pytest.approx(20.0)  # WP_SPEED to the first
    d.until(lambda: d.sim.current == 3)
    assert d.sim.speed == 5.0 and [e.value for e in d.sim.events if e.kind == "speed"] == [5.0]
    d.until(lambda: d.sim.current == 3 and d.sim.vn > 0)
    assert math.hypot(d.sim.vn, d.sim.ve) == pytest.approx(5.0)  # reported in the stream too
    # Measured on the simulator's clock: each leg after the change takes distance / 5 m/s.
    d.until(lambda: d.sim.complete)
    leg2 = d.times("arrived", 3)[0] - d.times("reached", 1)[0]
    leg3 = d.times("arrived", 4)[0] - d.times("reached", 3)[0]
    # WP_RADIUS 2 m: each leg runs from 2 m short of one waypoint to 2 m short of the next.
    assert leg2 == pytest.approx(100 / 5.0, abs=0.1)
    assert leg3 == pytest.approx(60 / 5.0, abs=0.1)
    assert d.times("reached", 2)  # the DO command is reported done, as Rover does
    assert "speed: 5.0 m/s" in d.texts()


@pytest.mark.parametrize("speed", [-1.0, 0.0])
def test_a_speed_change_of_minus_one_or_zero_changes_nothing(driven, speed):
    d = driven(speed_mps=20.0)
    m = build_mission(HOME, [north(50), {**north(100), "speed_mps": 3.0}, north(150)])
    items = [wp(i) for i in m]
    items[2].param2 = speed  # AR_WPNav::set_speed_max refuses anything under 0.05 m/s
    d.sim.load_mission(items)
    d.start()
    d.until(lambda: d.sim.current == 3 and d.sim.vn > 0)
    assert math.hypot(d.sim.vn, d.sim.ve) == pytest.approx(20.0)
    assert not [e for e in d.sim.events if e.kind == "speed"]


def test_a_hold_keeps_the_boat_at_its_waypoint_with_the_item_current_until_it_is_over(driven):
    d = driven()
    m = build_mission(HOME, [north(40), {**north(80), "hold_s": 3}, north(120)])
    d.start(m)
    d.until(lambda: d.times("arrived", 2))
    arrived = d.times("arrived", 2)[0]
    held_at = (d.sim.lat, d.sim.lon)
    d.until(lambda: d.now - arrived >= 2.5)
    assert d.sim.current == 2 and not d.times("reached", 2)  # still the current item
    assert (d.sim.lat, d.sim.lon) == held_at and (d.sim.vn, d.sim.ve) == (0.0, 0.0)
    d.until(lambda: d.times("reached", 2))
    assert d.times("reached", 2)[0] - arrived == pytest.approx(3.0, abs=2 * DT)
    assert "Reached waypoint #2. Loiter for 3 seconds" in d.texts()
    currents = [msg.seq for msg in d.heard if msg.get_type() == "MISSION_CURRENT"]
    assert 2 in currents and currents == sorted(currents)
    d.until(lambda: d.sim.complete)
    reached = [msg.seq for msg in d.heard if msg.get_type() == "MISSION_ITEM_REACHED"]
    assert reached == [1, 2, 3]


def test_a_loiter_time_item_holds_like_a_waypoint_hold(driven):
    d = driven()
    m = build_mission(HOME, [north(40), north(80)])
    items = [wp(i) for i in m]
    items[2] = replace(items[2], command=MAV_CMD_NAV_LOITER_TIME, param1=2.0)
    d.sim.load_mission(items)
    d.start()
    d.until(lambda: d.sim.complete)
    assert d.times("reached", 2)[0] - d.times("arrived", 2)[0] == pytest.approx(2.0, abs=2 * DT)
    assert "Finished active loiter" in d.texts()


def test_stop_ends_in_auto_with_the_boat_stopped_at_the_last_waypoint(driven):
    d = driven()
    last = north(80)
    d.start(build_mission(HOME, [north(40), last], end="stop"))
    d.until(lambda: d.sim.complete)
    for _ in range(50):
        d.step()
    assert d.sim.mode_name == "AUTO" and (d.sim.vn, d.sim.ve) == (0.0, 0.0)
    assert distance_m(d.sim.lat, d.sim.lon, last["lat"], last["lon"]) <= d.sim.wp_radius
    assert "Mission Complete" in d.texts()


def test_return_home_drives_home_in_auto_then_the_mission_completes(driven):
    d = driven()
    d.start(build_mission(HOME, [north(60), north(120)], end="return_home"))
    d.until(lambda: d.sim.current == 3)  # the NAV_RETURN_TO_LAUNCH
    assert d.sim.mode_name == "AUTO"  # Rover runs it as Auto's RTL sub-mode
    d.until(lambda: d.sim.complete)
    assert distance_m(d.sim.lat, d.sim.lon, *HOME) <= d.sim.wp_radius
    assert d.sim.mode_name == "AUTO" and d.times("reached", 3)
    texts = d.texts()
    assert texts.index("Reached destination") < texts.index("Mission Complete")


def test_a_loop_comes_back_to_item_1_forever(driven):
    d = driven()
    d.start(build_mission(HOME, [north(40), north(80)], end="loop"))
    d.until(lambda: len(d.times("reached", 1)) == 3)
    assert len(d.times("reached", 2)) == 2 and not d.sim.complete
    assert d.sim.mode_name == "AUTO"


def test_a_jump_with_a_repeat_count_runs_the_loop_that_many_more_times(driven):
    d = driven()
    m = build_mission(HOME, [north(40), north(80)], end="loop")
    items = [wp(i) for i in m]
    items[3] = replace(items[3], param2=2.0)  # DO_JUMP to 1, twice
    d.sim.load_mission(items)
    d.start()
    d.until(lambda: d.sim.complete)
    assert len(d.times("reached", 1)) == len(d.times("reached", 2)) == 3


def test_a_mission_read_back_is_the_one_uploaded_item_for_item(make_sim, make_link):
    sim = make_sim(lat=HOME[0], lon=HOME[1])
    link = make_link(sim.endpoint)
    items = [{**north(40), "speed_mps": 2.5, "hold_s": 4}, north(80),
             {**north(120), "hold_s": 1.5, "speed_mps": 1.0}]  # fmt: skip
    for end in ("stop", "loop", "return_home"):
        sent = build_mission(HOME, items, end=end)
        assert link.upload_mission(sent).ok
        down = link.download_mission()
        assert down.ok, down.error
        assert len(down.items) == len(sent)
        for got, want in zip(down.items, sent, strict=True):
            assert got.same_route(want), (got, want)


def test_rover_keeps_no_per_waypoint_radius_and_holds_in_whole_seconds(make_sim, make_link):
    sim = make_sim(lat=HOME[0], lon=HOME[1])
    link = make_link(sim.endpoint)
    sent = build_mission(HOME, [{**north(40), "radius_m": 7}])
    sent[1] = replace(sent[1], param1=2.7)  # as another ground station might send it
    assert link.upload_mission(sent).ok
    got = link.download_mission().items[1]
    assert (got.param1, got.param2) == (2.0, 0.0)  # AP_Mission: uint16 p1, radius Plane-only
    assert (got.x, got.y, got.frame) == (sent[1].x, sent[1].y, sent[1].frame)
