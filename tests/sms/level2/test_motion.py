"""The simulated C&C's glider moves as the commands it accepts say (sms.level2.motion), and the
C&C simulator reports where it has got to in its status requests."""

from __future__ import annotations

import pytest

from edge_client.contract.geo import bearing_deg, distance_m
from sms.level2.bodies import CommandPacket, StatusRequest
from sms.level2.inner import InnerCommandTable
from sms.level2.motion import Motion
from sms.level2.simulator import CcSimulator, SimConfig, VirtualClock

START = (-32.0800, 115.7000)  # off Fremantle
TABLE = InnerCommandTable.load()


def packet(text: str) -> CommandPacket:
    """The packet the bridge would send for ``text``: the shipped table encodes it."""
    return TABLE.parse(text).packet


def test_it_follows_its_heading_at_its_speed() -> None:
    motion = Motion(*START, heading_deg=90, speed_mps=2.0)
    assert motion.position(100.0) == START  # the first look starts the clock
    lat, lon = motion.position(160.0)
    assert distance_m(*START, lat, lon) == pytest.approx(120, rel=1e-3)
    assert bearing_deg(*START, lat, lon) == pytest.approx(90, abs=0.1)


@pytest.mark.parametrize("bearing", [0, 45, 230, 359])
def test_a_fixed_heading_from_the_table_turns_it(bearing: int) -> None:
    motion = Motion(*START, heading_deg=90, speed_mps=1.0)
    motion.position(0.0)
    assert motion.obey(packet(f"fhead {bearing}"), 0.0) == (
        f"following heading {bearing:03d}° at 1 m/s"
    )
    lat, lon = motion.position(300.0)
    assert distance_m(*START, lat, lon) == pytest.approx(300, rel=1e-3)
    off = (bearing_deg(*START, lat, lon) - bearing + 180) % 360 - 180
    assert off == pytest.approx(0, abs=0.2)


def test_the_old_course_runs_until_the_command_and_the_new_one_after() -> None:
    motion = Motion(*START, heading_deg=0, speed_mps=1.0)
    motion.position(0.0)
    motion.obey(packet("fhead 180"), 100.0)  # 100 m north by now, then south
    lat, lon = motion.position(150.0)
    assert distance_m(*START, lat, lon) == pytest.approx(50, abs=0.5)
    assert lat > START[0]  # still north of the start


def test_it_steers_for_a_waypoint_and_holds_there() -> None:
    target = (-32.0850, 115.6950)  # ~720 m south-west
    motion = Motion(*START, heading_deg=0, speed_mps=2.0)
    motion.position(0.0)
    doing = motion.obey(packet(f"waypoint 1 {target[0]} {target[1]}"), 0.0)
    assert doing is not None and doing.startswith("steering 2") and "-32.08500,115.69500" in doing
    halfway = motion.position(180.0)
    assert distance_m(*halfway, *target) == pytest.approx(distance_m(*START, *target) - 360, abs=2)
    assert motion.position(3600.0) == pytest.approx(target, abs=1e-6)
    assert motion.mode == "hold"
    assert motion.position(7200.0) == pytest.approx(target, abs=1e-6)


def test_hold_stops_it_and_other_commands_change_nothing() -> None:
    motion = Motion(*START, heading_deg=45, speed_mps=1.0)
    motion.position(0.0)
    assert motion.obey(packet("light on"), 10.0) is None
    assert motion.mode == "heading"
    here = motion.position(20.0)
    assert motion.obey(packet("hold"), 20.0) == f"holding station at {here[0]:.5f},{here[1]:.5f}"
    assert motion.position(500.0) == here


def fixes(sim: CcSimulator, polls: int) -> list[tuple[float, float]]:
    """The positions in the status requests the simulator sends with a fix."""
    seen = []
    for _ in range(polls):
        request = StatusRequest.from_bytes(sim._status_body())
        if request.valid:
            seen.append((request.lat / 600_000, request.lon / 600_000))
        sim.stats.polls += 1
        sim.clock.sleep(sim.period_s)
    return seen


class NoLink:
    def send(self, data: bytes, *, split: bool = False) -> None: ...

    def receive(self, timeout_s: float) -> None:
        return None


def test_the_simulator_reports_the_moving_position_and_turns_on_an_accepted_command() -> None:
    motion = Motion(*START, heading_deg=270, speed_mps=1.0)
    sim = CcSimulator(NoLink(), SimConfig(period_s=10.0, motion=motion), VirtualClock())
    seen = fixes(sim, 6)  # fixes every other poll: 20 s apart
    assert len(seen) == 3
    steps = [distance_m(*a, *b) for a, b in zip(seen, seen[1:], strict=False)]
    assert steps == pytest.approx([20, 20], abs=0.5)  # the L2 grid is 0.18 m
    assert all(b[1] < a[1] for a, b in zip(seen, seen[1:], strict=False))  # westward
    sim.payload_flags = 0  # the payload wants no result: the command is taken as accepted
    sim._command_received(0x30, b"\x00\x00" + bytes(packet("fhead 0")))
    assert motion.heading_deg == 0
    after = fixes(sim, 4)
    assert after[-1][0] > after[0][0]  # northward now


def test_a_refused_command_does_not_move_it() -> None:
    motion = Motion(*START, heading_deg=270, speed_mps=1.0)
    config = SimConfig(period_s=10.0, motion=motion, send_results=True, ack_policy=lambda i, p: 2)
    sim = CcSimulator(NoLink(), config, VirtualClock())
    sim._command_received(0x30, b"\x00\x00" + bytes(packet("fhead 0")))
    assert sim.stats.results_sent[2] == 1 and motion.heading_deg == 270
