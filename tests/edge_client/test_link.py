"""The MAVLink link and vehicle state against the simulated Rover."""

from __future__ import annotations

import time

import pytest

from edge_client.config import MavlinkConfig, ReadingSource
from edge_client.mavlink_link import MavlinkLink


def wait_for(predicate, timeout: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.05)
    return False


def test_state_follows_the_autopilot(make_sim, make_link):
    sim = make_sim(lat=-31.95, lon=115.86)
    link = make_link(sim.endpoint)
    assert wait_for(lambda: link.state.lat is not None and link.state.battery_v is not None)
    state = link.state
    assert (round(state.lat, 5), round(state.lon, 5)) == (-31.95, 115.86)
    assert state.mode == "HOLD" and state.armed is False
    assert 11 < state.battery_v < 13
    assert wait_for(lambda: link.state.home == (-31.95, 115.86))  # asked with REQUEST_MESSAGE
    fix = state.fix()
    assert fix["lat"] == -31.95 and fix["battery_v"] == state.battery_v
    assert abs(fix["time"] - time.time()) < 2 and fix["readings"]["armed"] == 0


def test_the_stream_rate_is_requested(make_sim, make_link):
    sim = make_sim(rate_hz=1)
    make_link(sim.endpoint)  # asks for 10 Hz
    assert wait_for(lambda: sim.sim.intervals[33] == 0.1)


def test_extra_readings_come_from_the_configured_message(make_sim):
    sim = make_sim()
    link = MavlinkLink(
        MavlinkConfig(connection=sim.endpoint),
        (ReadingSource("water_temp_c", "SCALED_PRESSURE", "temperature", 0.01),),
    )
    link.start()
    try:
        assert wait_for(lambda: "water_temp_c" in link.state.readings)
        assert link.state.readings["water_temp_c"] == 18.5
        assert wait_for(lambda: link.state.fix() is not None)
        assert link.state.fix()["readings"]["water_temp_c"] == 18.5
    finally:
        link.stop()


@pytest.mark.slow
def test_a_silent_autopilot_is_noticed_and_so_is_its_return(make_sim, make_link):
    sim = make_sim()
    link = make_link(sim.endpoint, silent_after_s=1.0)
    assert wait_for(lambda: link.state.fix() is not None)
    sim.sim.muted = True
    assert wait_for(lambda: not link.state.autopilot_ok())
    assert wait_for(lambda: link.state.was_silent)
    assert wait_for(lambda: link.state.fix() is None)  # no stale position under a fresh time
    sim.sim.muted = False
    assert wait_for(lambda: link.state.autopilot_ok())
    assert link.state.reconnects == 1


@pytest.mark.slow
def test_a_restarted_autopilot_is_picked_up_again(make_sim):
    first = make_sim()
    link = MavlinkLink(MavlinkConfig(connection=first.endpoint, silent_after_s=1.0))
    link.start()
    try:
        assert link.wait_heartbeat(5)
        first.stop()
        assert wait_for(lambda: not link.state.autopilot_ok())
        # The autopilot comes back on the same port after a reboot: state and streams resume.
        make_sim(port=first.port, lat=-31.0, lon=115.0)
        assert wait_for(lambda: link.state.autopilot_ok())
        assert wait_for(lambda: link.state.lat is not None and round(link.state.lat) == -31)
        assert link.state.reconnects == 1
    finally:
        link.stop()
