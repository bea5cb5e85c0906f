"""The executor against the simulated Rover over real MAVLink (UDP on localhost)."""

from __future__ import annotations

import threading
import time
import uuid

import pytest

from edge_client.config import CommandsConfig, MavlinkConfig
from edge_client.contract.geo import distance_m
from edge_client.executor import Command, CommandError, Executor, validate
from edge_client.mavlink_link import MavlinkLink
from edge_client.outbox import Outbox
from edge_client.sim.clock import ScaledClock
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import wait_until

START = (-31.98, 115.82)
NEAR = (-31.979, 115.8205)  # ~120 m from START
NEVER = 1e9  # a simulator position_delay_s that a test lowers to 0 when it wants the EKF ready


class FakeClock:
    """An injected monotonic clock whose sleep() moves time on instead of waiting."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        self.now += seconds


# The tests that wait on the boat driving, holding, booting or refusing run the simulated
# Rover's clock (motion, holds, streams, start-up, its timeouts) four times as fast, and the
# executor's own clock with it (fast_executor): the same story in a quarter of the time.
FAST = 4.0


def fast_executor(link: MavlinkLink, outbox: Outbox, config: CommandsConfig) -> Executor:
    """An executor whose waits (mode retries, backoffs, ready deadlines) pass at the
    simulator's FAST pace, as the vehicle's do: its 5 s of asking again take 1.25 s."""
    clock = ScaledClock(FAST)
    return Executor(
        link, outbox, config, clock=clock.monotonic, sleep=lambda s: time.sleep(s / FAST)
    )


def cmd(kind: str, **params) -> Command:
    return Command(uid=str(uuid.uuid4()), kind=kind, params=params)


def acks(outbox: Outbox, uid: str) -> list[tuple[str, str]]:
    return [(a.body["status"], a.body["detail"]) for a in outbox.peek("ack", 100)
            if a.body["uid"] == uid]  # fmt: skip


def statuses(outbox: Outbox, uid: str) -> list[str]:
    return [s for s, _ in acks(outbox, uid)]


def run_until_settled(executor: Executor, timeout: float = 15.0) -> None:
    deadline = time.monotonic() + timeout
    while executor.active is not None and time.monotonic() < deadline:
        executor.watch()
        time.sleep(0.05)
    assert executor.active is None, "command did not finish in time"


# -- pure validation ------------------------------------------------------------------------------


def test_validate_normalises_good_params():
    assert validate("move_to", {"lat": -31.9, "lon": 115}) == {"lat": -31.9, "lon": 115.0}
    assert validate("set_mode", {"mode": "guided"}) == {"mode": "GUIDED"}
    mission = validate("mission", {"items": [{"lat": 1, "lon": 2}], "loop": True})
    assert mission["items"] == [
        {"lat": 1.0, "lon": 2.0, "hold_s": 0.0, "radius_m": 0.0, "speed_mps": None}
    ]
    assert (mission["end"], mission["loop"]) == ("loop", True)


@pytest.mark.parametrize(
    ("kind", "params", "message"),
    [
        ("move_to", {"lat": 91, "lon": 0}, "outside"),
        ("move_to", {"lat": "x", "lon": 0}, "must be a number"),
        ("move_to", {"lat": True, "lon": 0}, "must be a number"),
        ("set_mode", {"mode": "WARP"}, "unknown Rover mode"),
        ("mission", {"items": []}, "no items"),
        ("mission", {"items": [{"lat": 0, "lon": 0}], "end": "sink"}, "mission end 'sink'"),
        ("mission", {"items": [{"lat": 0, "lon": 200}]}, "item 0: lon"),
        ("launch_torpedo", {}, "unknown command kind"),
    ],
)
def test_validate_refuses_bad_params_with_a_reason(kind, params, message):
    with pytest.raises(CommandError, match=message):
        validate(kind, params)


# -- dedupe ---------------------------------------------------------------------------------------


def raw(uid: str, kind: str = "hold") -> dict:
    return {"uid": uid, "kind": kind, "params": {}, "created_at": "2026-01-01T00:00:00Z",
            "expires_at": None}  # fmt: skip


def test_a_command_offered_many_times_is_queued_once(tmp_path, commands_config):
    box = Outbox(tmp_path / "o.sqlite3")
    link = MavlinkLink(MavlinkConfig(connection="udpout:127.0.0.1:9"))
    executor = Executor(link, box, commands_config)
    assert executor.offer([raw("a"), raw("b")]) == 2
    assert executor.offer([raw("a"), raw("b"), raw("a")]) == 0
    assert executor.offer([raw("c"), {"kind": "hold"}]) == 1  # one without a uid is skipped
    box.close()
    # After a restart the same uids are still known: the SPAB client re-ran them on every poll.
    box = Outbox(tmp_path / "o.sqlite3")
    executor = Executor(link, box, commands_config)
    assert executor.offer([raw("a"), raw("b"), raw("c"), raw("d")]) == 1
    box.close()


def test_commands_interrupted_by_a_restart_are_failed_with_the_reason(outbox, commands_config):
    outbox.command_claim("u1", "move_to")
    link = MavlinkLink(MavlinkConfig(connection="udpout:127.0.0.1:9"))
    Executor(link, outbox, commands_config).recover()
    assert acks(outbox, "u1") == [("failed", "edge client restarted while the command was running")]
    assert outbox.commands_interrupted() == []


def test_without_an_autopilot_a_command_fails_with_the_reason(outbox, commands_config):
    link = MavlinkLink(MavlinkConfig(connection="udpout:127.0.0.1:9"))
    clock = FakeClock()
    executor = Executor(link, outbox, commands_config, clock=clock, sleep=clock.sleep)
    c = cmd("move_to", lat=1.0, lon=2.0)
    executor.execute(c)
    assert acks(outbox, c.uid) == [
        ("failed", "autopilot not reachable: no HEARTBEAT from the autopilot within 120 s")
    ]
    assert 1120 <= clock.now < 1121  # it waited ready_timeout_s for one


@pytest.mark.slow
def test_a_command_polled_before_the_autopilot_is_heard_waits_for_it(
    make_sim, outbox, commands_config
):
    port = free_port()
    link = MavlinkLink(MavlinkConfig(connection=f"udpout:127.0.0.1:{port}", stream_rate_hz=10))
    link.start()
    try:
        executor = Executor(link, outbox, commands_config)
        c = cmd("hold")
        running = threading.Thread(target=executor.execute, args=(c,))
        running.start()
        wait_until(lambda: executor.executed == [c.uid], 5, "the command to start")
        make_sim(port=port)  # the autopilot finishes booting
        running.join(15)
        assert statuses(outbox, c.uid) == ["acknowledged", "done"], acks(outbox, c.uid)
    finally:
        link.stop()


# -- against the simulator ------------------------------------------------------------------------


@pytest.mark.slow
def test_move_to_arms_goes_guided_and_is_done_on_arrival(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim(prearm_delay_s=2.0, time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = fast_executor(link, outbox, commands_config)
    c = cmd("move_to", lat=NEAR[0], lon=NEAR[1])
    executor.execute(c)  # waits out the pre-arm checks first
    assert statuses(outbox, c.uid) == ["acknowledged"]
    assert sim.sim.armed and sim.sim.mode_name == "GUIDED"
    assert any("PreArm" in t for t in link.state.statustext)
    run_until_settled(executor)
    status, detail = acks(outbox, c.uid)[-1]
    assert status == "done" and "arrived within" in detail
    assert link.state.distance_to(*NEAR) <= commands_config.acceptance_radius_m


def test_arm_before_move_can_be_turned_off(make_sim, make_link, outbox):
    sim = make_sim()
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, CommandsConfig(arm_before_move=False))
    c = cmd("move_to", lat=NEAR[0], lon=NEAR[1])
    executor.execute(c)
    assert acks(outbox, c.uid) == [("failed", "vehicle is disarmed and arm_before_move is off")]
    assert not sim.sim.armed


@pytest.mark.slow
def test_arming_gives_up_after_the_timeout_with_the_prearm_reason(make_sim, make_link, outbox):
    sim = make_sim(prearm_delay_s=60)
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, CommandsConfig(arm_timeout_s=1.5))
    c = cmd("arm")
    executor.execute(c)
    ((status, detail),) = acks(outbox, c.uid)
    assert status == "failed" and "PreArm: Waiting for position estimate" in detail


def test_hold_resume_return_home_set_mode_arm_disarm(make_sim, make_link, outbox, commands_config):
    sim = make_sim(time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = fast_executor(link, outbox, commands_config)
    for command, mode in [(cmd("hold"), "HOLD"), (cmd("return_home"), "RTL"),
                          (cmd("set_mode", mode="MANUAL"), "MANUAL")]:  # fmt: skip
        executor.execute(command)
        run_until_settled(executor)  # return_home: done on arrival (it is already home)
        assert statuses(outbox, command.uid) == ["acknowledged", "done"], acks(outbox, command.uid)
        assert sim.sim.mode_name == mode
    disarm = cmd("disarm")
    executor.execute(disarm)
    assert statuses(outbox, disarm.uid) == ["acknowledged", "done"] and not sim.sim.armed
    resume = cmd("resume")  # AUTO without a mission: Rover refuses
    executor.execute(resume)
    ((status, detail),) = acks(outbox, resume.uid)
    assert status == "failed" and "refused mode AUTO" in detail


@pytest.mark.slow
def test_return_home_is_done_on_arrival_not_when_rtl_is_accepted(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim(time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = fast_executor(link, outbox, commands_config)
    away = cmd("move_to", lat=NEAR[0], lon=NEAR[1])
    executor.execute(away)
    run_until_settled(executor)
    assert link.state.home == START
    c = cmd("return_home")
    executor.execute(c)
    assert statuses(outbox, c.uid) == ["acknowledged"] and sim.sim.mode_name == "RTL"
    run_until_settled(executor)
    status, detail = acks(outbox, c.uid)[-1]
    # Whichever comes first: our position within the radius, or Rover's "Reached destination"
    # (our position lags it by up to one GLOBAL_POSITION_INT, 10 m at 100 m/s).
    assert status == "done" and ("home: arrived within" in detail or "reached home" in detail)
    wait_until(lambda: link.state.distance_to(*START) < 3, 5, "the position at home")


@pytest.mark.slow
def test_return_home_without_a_known_home_is_done_when_rover_says_it_arrived(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim(time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = fast_executor(link, outbox, commands_config)
    executor.execute(cmd("move_to", lat=NEAR[0], lon=NEAR[1]))
    run_until_settled(executor)
    link.on("HOME_POSITION", lambda msg: setattr(link.state, "home", None))  # it never arrives
    link.state.home = None
    c = cmd("return_home")
    executor.execute(c)
    run_until_settled(executor)
    assert acks(outbox, c.uid)[-1] == (
        "done", "the autopilot reports it reached home and holds there"
    )  # fmt: skip
    assert sim.sim.mode_name == "RTL"
    # Our position lags the STATUSTEXT by up to one GLOBAL_POSITION_INT (10 m at 100 m/s).
    wait_until(lambda: link.state.distance_to(*START) < 3, 5, "the position at home")


@pytest.mark.slow
def test_return_home_fails_if_the_mode_changes_before_arrival(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim(time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = fast_executor(link, outbox, commands_config)
    executor.execute(cmd("move_to", lat=NEAR[0], lon=NEAR[1]))
    run_until_settled(executor)
    c = cmd("return_home")
    executor.execute(c)
    sim.sim.mode = 0  # someone on the radio takes over: MANUAL
    run_until_settled(executor)
    assert acks(outbox, c.uid)[-1] == ("failed", "mode changed to MANUAL before reaching home")


def test_a_refused_mode_change_fails_the_command(make_sim, make_link, outbox, commands_config):
    sim = make_sim(refuse_modes=("LOITER",))
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    wait_until(lambda: link.state.position_ready()[0], 5, "the EKF report")
    c = cmd("set_mode", mode="LOITER")
    executor.execute(c)
    # Refused although the autopilot has a position: no waiting, and its reason is given.
    assert acks(outbox, c.uid) == [
        ("failed", "autopilot refused mode LOITER: DENIED (Mode change to LOITER refused)")
    ]


@pytest.mark.slow
def test_a_move_to_sent_while_the_autopilot_gets_its_position_waits_for_it(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim(prearm_delay_s=0, position_delay_s=NEVER, time_scale=FAST)
    link = make_link(sim.endpoint)
    wait_until(lambda: link.state.position_ready()[0] is False, 5, "an EKF report, not ready")
    executor = fast_executor(link, outbox, commands_config)
    c = cmd("move_to", lat=NEAR[0], lon=NEAR[1])
    running = threading.Thread(target=executor.execute, args=(c,))
    running.start()
    wait_until(lambda: "Flight mode change failed" in link.state.statustext, 5, "a refusal")
    assert sim.sim.armed and sim.sim.mode_name == "HOLD"
    assert acks(outbox, c.uid) == []  # refused, but not given up
    sim.sim.position_delay_s = 0  # the EKF converges
    running.join(15)
    assert statuses(outbox, c.uid) == ["acknowledged"] and sim.sim.mode_name == "GUIDED"
    run_until_settled(executor)
    assert statuses(outbox, c.uid) == ["acknowledged", "done"]


def test_the_wait_for_a_position_ends_at_the_deadline_with_the_autopilots_reason(
    make_sim, make_link, outbox
):
    sim = make_sim(prearm_delay_s=0, position_delay_s=NEVER)
    link = make_link(sim.endpoint)
    wait_until(lambda: link.state.position_ready()[0] is False, 5, "an EKF report, not ready")
    clock = FakeClock()
    config = CommandsConfig(arm_timeout_s=5, ready_timeout_s=90)
    executor = Executor(link, outbox, config, clock=clock, sleep=clock.sleep)
    c = cmd("return_home")
    executor.execute(c)
    ((status, detail),) = acks(outbox, c.uid)
    assert status == "failed"
    # (…; the autopilot last said: EKF failsafe) follows once the simulator has raised it.
    assert detail.startswith(
        "autopilot refused mode RTL: FAILED (Flight mode change failed); not ready after 90 s: "
        "EKF in constant-position mode (no position yet)"
    )
    assert 1090 <= clock.now <= 1095 and sim.sim.mode_name == "HOLD"


@pytest.mark.slow
def test_a_command_arriving_during_boot_succeeds_once_the_ekf_failsafe_clears(
    make_sim, make_link, outbox
):
    # Rover's start-up order: armed without a position, "EKF failsafe"; then the position
    # ("EKF3 IMU0 is using GPS"), GUIDED still refused; "EKF failsafe cleared" 3 s later.
    sim = make_sim(prearm_delay_s=0, position_delay_s=3.0, ekf_failsafe_s=3.0, time_scale=FAST)
    link = make_link(sim.endpoint)
    config = CommandsConfig(arm_timeout_s=5, ready_timeout_s=30, acceptance_radius_m=5)
    executor = fast_executor(link, outbox, config)
    c = cmd("move_to", lat=NEAR[0], lon=NEAR[1])
    executor.execute(c)
    assert statuses(outbox, c.uid) == ["acknowledged"], acks(outbox, c.uid)
    said = list(link.state.statustext)
    using_gps = said.index("EKF3 IMU0 is using GPS")
    assert "EKF failsafe" in said[:using_gps]
    # Refused once the position was there: the single retry of old ended the command here.
    assert "Flight mode change failed" in said[using_gps : said.index("EKF failsafe cleared")]
    assert sim.sim.mode_name == "GUIDED"
    run_until_settled(executor)
    assert statuses(outbox, c.uid) == ["acknowledged", "done"]


def test_a_failsafe_that_never_clears_fails_at_the_deadline_in_the_autopilots_words(
    make_sim, make_link, outbox
):
    sim = make_sim(prearm_delay_s=0, position_delay_s=NEVER, ekf_failsafe_s=NEVER)
    link = make_link(sim.endpoint)
    assert link.arm(5) == (True, "armed")
    wait_until(lambda: link.state.ekf_failsafe, 5, 'the autopilot saying "EKF failsafe"')
    sim.sim.position_delay_s = 0  # the position comes; the failsafe stays
    wait_until(lambda: link.state.position_ready()[0], 5, "a position")
    wait_until(lambda: "EKF3 IMU0 is using GPS" in link.state.statustext, 5, "the EKF's word")
    clock = FakeClock()
    config = CommandsConfig(arm_timeout_s=5, ready_timeout_s=30)
    executor = Executor(link, outbox, config, clock=clock, sleep=clock.sleep)
    c = cmd("move_to", lat=NEAR[0], lon=NEAR[1])
    executor.execute(c)
    assert acks(outbox, c.uid) == [(
        "failed",
        "autopilot refused mode GUIDED: FAILED (Flight mode change failed); not ready after "
        "30 s: the autopilot's EKF failsafe has not cleared; "
        "the autopilot last said: EKF3 IMU0 is using GPS",
    )]  # fmt: skip
    assert 1030 <= clock.now <= 1032 and sim.sim.mode_name == "HOLD"


def test_a_refusal_that_outlasts_the_start_up_fails_without_waiting_for_the_deadline(
    make_sim, make_link, outbox
):
    sim = make_sim(prearm_delay_s=0)  # warm: position good, no failsafe
    link = make_link(sim.endpoint)
    wait_until(lambda: link.state.position_ready()[0], 5, "a position")
    clock = FakeClock()
    executor = Executor(link, outbox, CommandsConfig(arm_timeout_s=5), clock=clock,
                        sleep=clock.sleep)  # fmt: skip
    c = cmd("resume")  # AUTO without a mission: refused FAILED, as at start-up, but for good
    executor.execute(c)
    ((status, detail),) = acks(outbox, c.uid)
    assert (status, detail) == (
        "failed",
        "autopilot refused mode AUTO: FAILED (AutoMode: no mission); still refused 5 s after "
        "the position was good (EKF has a horizontal position)",
    )
    assert 1005 <= clock.now <= 1008  # asked again for a while, not for ready_timeout_s (120)


def test_a_newer_navigation_command_replaces_the_active_one(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim(speed_mps=2)
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    first, second = cmd("move_to", lat=NEAR[0], lon=NEAR[1]), cmd("hold")
    executor.execute(first)
    executor.execute(second)
    assert acks(outbox, first.uid)[-1] == (
        "superseded",
        f"replaced by hold command {second.uid}",
    )
    assert statuses(outbox, second.uid) == ["acknowledged", "done"]


WAYPOINTS = [
    {"lat": -31.9795, "lon": 115.8205, "hold_s": 0, "radius_m": 3},
    {"lat": -31.9790, "lon": 115.8200, "hold_s": 0.5, "radius_m": None},
    {"lat": -31.9795, "lon": 115.8195, "hold_s": 0, "radius_m": 2},
]


@pytest.mark.slow
@pytest.mark.parametrize("request_int", [False, True])
def test_mission_is_uploaded_with_home_first_and_run_to_the_end(
    make_sim, make_link, outbox, commands_config, request_int
):
    sim = make_sim(request_int=request_int, time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    c = cmd("mission", mission_id=7, items=WAYPOINTS, loop=False)
    executor.execute(c)
    assert statuses(outbox, c.uid) == ["acknowledged"], acks(outbox, c.uid)
    stored = sim.sim.mission
    assert [(i.x, i.y) for i in stored[1:]] == [(round(w["lat"] * 1e7), round(w["lon"] * 1e7))
                                                for w in WAYPOINTS]  # fmt: skip
    assert (stored[0].x, stored[0].y) == (round(START[0] * 1e7), round(START[1] * 1e7))
    run_until_settled(executor)
    assert acks(outbox, c.uid)[-1] == ("done", "mission complete (3 of 3)")
    assert sim.sim.mode_name == "AUTO" and sim.sim.complete  # Rover stops, still in AUTO


# Five waypoints ~30 m apart, speed changes (to 20 m/s, the catalog's most) before 1 and 3.
FIVE = [
    {"lat": -31.9795 + (i % 2) * 0.00025, "lon": 115.8195 + i * 0.0001, "hold_s": 0,
     "radius_m": None, "speed_mps": 20.0 if i in (0, 2) else None}
    for i in range(5)
]  # fmt: skip


@pytest.mark.slow
def test_mission_progress_is_in_the_operators_waypoint_numbers(
    make_sim, make_link, outbox, commands_config, caplog
):
    sim = make_sim(time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    c = cmd("mission", mission_id=5, items=FIVE, end="stop")
    caplog.set_level("INFO", logger="edge_client.executor")
    executor.execute(c)
    readings = []  # what the fixes say while it runs
    deadline = time.monotonic() + 20
    while executor.active is not None and time.monotonic() < deadline:
        executor.watch()
        readings.append(link.state.fix()["readings"])
        time.sleep(0.02)
    # Seven MAVLink items after home (two speed changes): the last waypoint is item 7.
    assert [e.seq for e in sim.sim.events if e.kind == "reached"][-1] == 7
    assert acks(outbox, c.uid)[-1] == ("done", "mission complete (5 of 5)")
    on_the_way = {(r["mission_item"], r["waypoint"], r["waypoints"]) for r in readings
                  if "waypoint" in r}  # fmt: skip
    assert (5, 3, 5) in on_the_way and (7, 5, 5) in on_the_way
    said = [r.getMessage() for r in caplog.records if "reached waypoint" in r.getMessage()]
    assert said[-1] == f"command {c.uid}: reached waypoint 5 of 5"


@pytest.mark.slow
def test_a_mission_ending_home_is_done_once_the_final_rtl_has_brought_the_boat_home(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim(time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    items = [{**WAYPOINTS[0], "speed_mps": 20.0}, *WAYPOINTS[1:]]
    c = cmd("mission", mission_id=3, items=items, end="return_home")
    executor.execute(c)  # the boat starts at home: that must not count as being back
    assert statuses(outbox, c.uid) == ["acknowledged"], acks(outbox, c.uid)
    run_until_settled(executor)
    status, detail = acks(outbox, c.uid)[-1]
    assert status == "done", detail
    rtl = len(sim.sim.mission) - 1  # home, speed, 3 waypoints, RTL
    assert rtl == 5 and [e.seq for e in sim.sim.events if e.kind == "arrived"][-1] == rtl
    # Where the simulator is (our own position reports may still be a moment behind).
    assert distance_m(sim.sim.lat, sim.sim.lon, *START) <= sim.sim.wp_radius
    assert sim.sim.mode_name == "AUTO"  # Rover's mission RTL is a sub-mode of AUTO


@pytest.mark.slow
@pytest.mark.parametrize(
    ("end", "said"),
    # return_home: Rover's "Reached destination", or our own position once RTL is current.
    [("stop", "the autopilot says so"), ("return_home", "home")],
)
def test_a_mission_whose_item_reached_reports_are_lost_ends_on_rovers_own_words(
    make_sim, make_link, outbox, commands_config, end, said
):
    sim = make_sim(lose=("MISSION_ITEM_REACHED",), time_scale=FAST)
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    c = cmd("mission", mission_id=3, items=WAYPOINTS, end=end)
    executor.execute(c)
    run_until_settled(executor)
    status, detail = acks(outbox, c.uid)[-1]
    assert (status, said in detail) == ("done", True), detail
    assert link.state.last_reached is None and sim.sim.complete


def test_a_hold_longer_than_rover_can_keep_fails_before_anything_is_sent(
    make_sim, make_link, outbox, commands_config
):
    sim = make_sim()
    executor = Executor(make_link(sim.endpoint), outbox, commands_config)
    c = cmd("mission", mission_id=3, items=[{**WAYPOINTS[0], "hold_s": 40000}])
    executor.execute(c)
    # The catalog's range is Rover's 16-bit limit, so the boat's own check refuses it first.
    assert acks(outbox, c.uid) == [("failed", "item 0: hold_s 40000 is outside 0…32767")]
    assert sim.sim.mission == []


def test_a_looping_mission_is_done_once_running(make_sim, make_link, outbox, commands_config):
    sim = make_sim()
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    c = cmd("mission", mission_id=None, items=WAYPOINTS, loop=True)
    executor.execute(c)
    assert statuses(outbox, c.uid) == ["acknowledged", "done"]
    assert sim.sim.mission[-1].command == 177 and sim.sim.mode_name == "AUTO"


def test_a_rejected_mission_fails_with_the_error_code(make_sim, make_link, outbox, commands_config):
    sim = make_sim(reject_mission=4)
    link = make_link(sim.endpoint)
    executor = Executor(link, outbox, commands_config)
    c = cmd("mission", mission_id=1, items=WAYPOINTS, loop=False)
    executor.execute(c)
    ((status, detail),) = acks(outbox, c.uid)
    assert status == "failed"
    assert detail == "mission upload failed: autopilot rejected the mission: MAV_MISSION_NO_SPACE"
    assert sim.sim.mission == []


@pytest.mark.slow
def test_mission_upload_survives_a_lossy_link(make_sim, make_link, outbox, commands_config):
    sim = make_sim(drop=0.15, dup=0.2, seed=3)
    link = make_link(sim.endpoint, silent_after_s=10)
    c = cmd("mission", mission_id=1, items=WAYPOINTS * 3, loop=False)
    upload = link.upload_mission(
        __import__("edge_client.mission", fromlist=["build_mission"]).build_mission(
            START, c.params["items"]
        )
    )
    assert upload.ok, upload.error
    assert len(sim.sim.mission) == 10
    assert sim.sim.counts["dropped"] > 0 and sim.sim.counts["duplicated"] > 0


def test_unknown_kinds_fail(make_sim, make_link, outbox, commands_config):
    sim = make_sim()
    executor = Executor(make_link(sim.endpoint), outbox, commands_config)
    c = cmd("fhead", bearing=230)
    executor.execute(c)
    assert acks(outbox, c.uid) == [("failed", "unknown command kind 'fhead'")]
