"""The simulator reads all its time from one injected clock, so tests can run it fast."""

from __future__ import annotations

import os
import time
from itertools import pairwise

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from edge_client.sim.clock import ScaledClock  # noqa: E402
from edge_client.sim.mission import UPLOAD_GIVE_UP_S, UPLOAD_RETRY_S  # noqa: E402
from edge_client.sim.rover import EKF_USING_GPS, RoverSim  # noqa: E402
from tests.edge_client.conftest import free_port  # noqa: E402

m = mavutil.mavlink
DT = 0.05  # clock seconds per step


class HostClock:
    """Stands in for the host's time.monotonic and time.time, moved on by hand."""

    def __init__(self) -> None:
        self.t, self.wall = 100.0, 1_700_000_000.0

    def monotonic(self) -> float:
        return self.t

    def time(self) -> float:
        return self.wall + self.t - 100.0


def test_a_scaled_clock_runs_scale_times_faster_from_when_it_is_made():
    host = HostClock()
    clock = ScaledClock(4.0, monotonic=host.monotonic, wall=host.time)
    host.t += 2.5
    assert clock.monotonic() == pytest.approx(100.0 + 10.0)
    assert clock.time() == pytest.approx(host.wall + 10.0)


def test_scale_one_is_the_hosts_own_clock():
    host = HostClock()
    clock = ScaledClock(1.0, monotonic=host.monotonic, wall=host.time)
    host.t += 3.0
    assert (clock.monotonic(), clock.time()) == (host.monotonic(), host.time())


@pytest.mark.parametrize("scale", [0.0, -2.0])
def test_a_scale_that_does_not_run_forward_is_refused(scale):
    with pytest.raises(ValueError, match="time scale must be positive"):
        ScaledClock(scale)


class OnAClock:
    """A simulator on ``HostClock`` with a GCS peer: ``run`` steps it with ``step()`` as its own
    thread does (no time given), moving the clock on by hand, and records what the GCS heard
    with the clock's time it was heard at."""

    def __init__(self, **options) -> None:
        port = free_port()
        self.clock = HostClock()
        self.sim = RoverSim([f"udpin:127.0.0.1:{port}"], clock=self.clock, **options)
        self.gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255,
                                              source_component=190)  # fmt: skip
        self.heard: list[tuple[float, object]] = []
        self.gcs.mav.heartbeat_send(6, 8, 0, 0, 0)
        deadline = time.monotonic() + 5
        while not self.sim.peers:  # the UDP peer is known once its first packet is read
            assert time.monotonic() < deadline, "the simulator never heard the GCS"
            self.sim.step()
            time.sleep(0.001)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds / DT)):
            self.clock.t += DT
            self.sim.step()
            self._drain()
        time.sleep(0.05)  # the last datagrams, in real time
        self._drain()

    def _drain(self) -> None:
        while (msg := self.gcs.recv_msg()) is not None:
            self.heard.append((self.clock.t - 100.0, msg))

    def of(self, kind: str) -> list[tuple[float, object]]:
        return [(t, msg) for t, msg in self.heard if msg.get_type() == kind]

    def close(self) -> None:
        self.gcs.close()
        self.sim.close()


@pytest.fixture
def on_a_clock():
    made: list[OnAClock] = []

    def make(**options) -> OnAClock:
        made.append(OnAClock(**options))
        return made[-1]

    yield make
    for s in made:
        s.close()


def test_streams_boot_time_and_utc_follow_the_injected_clock(on_a_clock):
    s = on_a_clock(rate_hz=4.0)
    started = time.monotonic()
    s.run(6.0)  # six seconds on the clock, a fraction of one in real time
    assert time.monotonic() - started < 6.0
    positions = s.of("GLOBAL_POSITION_INT")
    # 4 Hz for 6 s of the clock (each send falls on a step, so up to DT late).
    assert 6.0 / (0.25 + DT) <= len(positions) <= 6.0 / 0.25 + 1
    assert positions[-1][1].time_boot_ms == pytest.approx(6000, abs=2 * DT * 1000)
    assert 5 <= len(s.of("HEARTBEAT")) <= 8  # 1 Hz, plus the greeting to a new peer
    t, system_time = s.of("SYSTEM_TIME")[-1]
    assert system_time.time_unix_usec / 1e6 == pytest.approx(s.clock.wall + t, abs=2 * DT)


def test_the_start_up_order_runs_on_the_injected_clock(on_a_clock):
    s = on_a_clock(position_delay_s=4.0)
    s.run(6.0)
    gps_fix = next(t for t, msg in s.of("GPS_RAW_INT") if msg.fix_type == 3)
    home = s.of("HOME_POSITION")[0][0]
    using_gps = next(t for t, msg in s.of("STATUSTEXT") if msg.text == EKF_USING_GPS)
    # GPS fix and home at half the position delay, the EKF's position at the whole of it.
    assert home == pytest.approx(2.0, abs=2 * DT) and 2.0 - DT <= gps_fix <= 3.0 + DT
    assert using_gps == pytest.approx(4.0, abs=2 * DT)


def test_upload_retries_and_give_up_are_on_the_injected_clock(on_a_clock):
    s = on_a_clock()
    s.gcs.mav.mission_count_send(1, 1, 2)  # and then never send an item
    deadline = time.monotonic() + 5
    while s.sim.upload is None:
        assert time.monotonic() < deadline, "the simulator never took the MISSION_COUNT"
        s.sim.step()
        time.sleep(0.001)
    s.run(UPLOAD_GIVE_UP_S + 1.0)
    requests = [t for t, _ in s.of("MISSION_REQUEST")]
    (cancelled, ack), *_ = s.of("MISSION_ACK")
    assert ack.type == m.MAV_MISSION_OPERATION_CANCELLED
    assert cancelled == pytest.approx(UPLOAD_GIVE_UP_S, abs=3 * DT)
    # Asked again each time UPLOAD_RETRY_S passes unanswered, until it gives up.
    assert len(requests) == pytest.approx(UPLOAD_GIVE_UP_S / (UPLOAD_RETRY_S + DT), abs=2)
    # (each heard up to a step after it was sent)
    gaps = [later - earlier for earlier, later in pairwise(requests)]
    assert all(gap >= UPLOAD_RETRY_S - DT for gap in gaps), gaps
