"""Fixtures for the edge client tests: free ports, an in-thread simulated Rover, a live link."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator

import pytest

from edge_client.config import CommandsConfig, MavlinkConfig
from edge_client.mavlink_link import MavlinkLink
from edge_client.outbox import Outbox
from edge_client.sim import RoverSim

FAST_SIM = {"speed_mps": 100.0, "rate_hz": 10.0, "prearm_delay_s": 0.5}


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class SimThread:
    """A RoverSim stepping in a background thread; ``endpoint`` is what a client connects to."""

    def __init__(self, port: int | None = None, **options) -> None:
        self.port = port or free_port()
        self.sim = RoverSim([f"udpin:127.0.0.1:{self.port}"], **{**FAST_SIM, **options})
        self.endpoint = f"udpout:127.0.0.1:{self.port}"
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self.sim.run, args=(self._stop,), daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5)


@pytest.fixture
def make_sim() -> Iterator:
    started: list[SimThread] = []

    def make(**options) -> SimThread:
        sim = SimThread(**options)
        started.append(sim)
        return sim

    yield make
    for sim in started:
        sim.stop()


@pytest.fixture
def make_link() -> Iterator:
    links: list[MavlinkLink] = []

    def make(endpoint: str, **options) -> MavlinkLink:
        link = MavlinkLink(MavlinkConfig(connection=endpoint, stream_rate_hz=10, **options))
        link.start()
        assert link.wait_heartbeat(5), "no HEARTBEAT from the simulator"
        links.append(link)
        return link

    yield make
    for link in links:
        link.stop()


@pytest.fixture
def outbox(tmp_path) -> Iterator[Outbox]:
    box = Outbox(tmp_path / "outbox.sqlite3", max_fixes=100)
    yield box
    box.close()


@pytest.fixture
def commands_config() -> CommandsConfig:
    return CommandsConfig(arm_timeout_s=5.0, acceptance_radius_m=5.0)
