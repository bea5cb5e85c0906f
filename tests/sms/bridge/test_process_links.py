"""The bridge outlives its links: a Level 2 port that goes away and comes back is reopened, and
a database that drops every connection (a PostgreSQL restart) costs one retry, not the process
(issue 11 §1)."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator

import pytest
from django.db import connection

from commands.models import Command
from sms.bridge.process import Bridge, BridgeConfig
from sms.level2.runner import SerialLink
from sms.level2.simulator import CcSimulator, SimConfig, VirtualClock
from sms.modem.simulator import ModemServer, SimulatedModem
from vessels.models import Vessel

from .rig import CONTROL, FAST_MODEM, FAST_SIM, QUERY, authorise, running_bridge, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]


class SocketPort:
    """The C&C's end of a TCP connection with the small port API SerialLink uses."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.sock.settimeout(0.05)

    @property
    def in_waiting(self) -> int:
        return 0

    def read(self, size: int = 1) -> bytes:
        try:
            return self.sock.recv(max(size, 1))
        except TimeoutError:
            return b""

    def write(self, data: bytes) -> int:
        self.sock.sendall(data)
        return len(data)

    def flush(self) -> None:
        pass

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def listener() -> Iterator[socket.socket]:
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(10)
    yield server
    server.close()


def cc_on(sock: socket.socket) -> CcSimulator:
    sim = CcSimulator(SerialLink(SocketPort(sock)), SimConfig(**FAST_SIM), VirtualClock())  # type: ignore[arg-type]
    assert wait_for(sim.enumerate)
    return sim


def test_a_level2_connection_that_drops_is_reopened(
    glider: Vessel, listener: socket.socket
) -> None:
    authorise(glider)
    modem = SimulatedModem()
    server = ModemServer(modem, "pty").start()
    port = listener.getsockname()[1]
    config = BridgeConfig(
        vessel=glider.slug,
        level2_port=f"socket://127.0.0.1:{port}",
        modem_port=server.url,
        poll_period_s=1,
        reply_window_s=10.0,
        tick_s=0.05,
        reconnect_delay_s=0.05,
    )
    bridge = Bridge(config, vessel=glider, modem_config=FAST_MODEM)
    thread = threading.Thread(target=bridge.run, daemon=True)
    thread.start()
    try:
        first, _ = listener.accept()
        cc_on(first).poll_once()
        first.close()  # the cable pulled
        second, _ = listener.accept()  # the bridge dials again
        sim = cc_on(second)
        modem.inject(CONTROL, "#FHEAD 230")
        assert wait_for(lambda: Command.objects.filter(vessel=glider).exists())
        sim.poll_once()
        assert wait_for(lambda: modem.sent)
        second.close()
    finally:
        bridge.stop()
        thread.join(15)
        server.stop()
    assert [s.text for s in modem.sent] == ["#FHEAD 230 OK"]
    assert bridge.runner.opens >= 2


def test_sms_are_answered_after_the_database_drops_every_connection(glider: Vessel) -> None:
    if connection.vendor != "postgresql":
        pytest.skip("SQLite has no server to restart; run the suite with DATABASE_URL")
    authorise(glider)
    with running_bridge(glider) as rig:
        sim = rig.cc()
        sim.poll_once()  # the Level 2 thread has its connection
        rig.modem.inject(QUERY, "#FHEAD")
        assert wait_for(lambda: rig.modem.sent)
        with connection.cursor() as cursor:  # what a restart does to the bridge's connections
            cursor.execute(
                "SELECT count(pg_terminate_backend(pid)) FROM pg_stat_activity"
                " WHERE datname = current_database() AND pid <> pg_backend_pid()"
            )
        rig.modem.inject(QUERY, "#LIGHT")
        assert wait_for(lambda: len(rig.modem.sent) == 2, 20)
        # The Level 2 thread lost its connection too: a status poll may flag nothing while it
        # reconnects; the next one hands the command over.
        rig.modem.inject(CONTROL, "#FHEAD 230")
        assert wait_for(lambda: Command.objects.filter(vessel=glider).exists())
        for _ in range(3):
            sim.poll_once()
            if sim.stats.commands:
                break
        assert wait_for(lambda: len(rig.modem.sent) == 3, 20)
        assert all(t.is_alive() for t in rig.bridge.threads)
    assert [text for _, text in rig.texts()] == [
        "#FHEAD unknown",
        "#LIGHT unknown",
        "#FHEAD 230 OK",
    ]
