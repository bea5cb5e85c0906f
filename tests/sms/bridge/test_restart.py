"""``manage.py run_wg_bridge`` as a real process, killed with SIGKILL at each step of a handover
and started again: every command handed over exactly once, every SMS answered once (issue 11,
Tests: faults; §8.5, §8.6, §10 of docs/level2.md)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from django.db import connection

from commands.lifecycle import Status
from commands.models import Command
from sms.level2.bodies import AckNakQueued, StatusReply, StatusRequest
from sms.level2.codec import CC_MAIN, Address, Frame, MessageType
from sms.level2.runner import PtyPort, SerialLink
from sms.level2.simulator import CcSimulator, SimConfig, VirtualClock
from sms.models import Direction, SendStatus, SmsMessage
from sms.modem.simulator import ModemServer, SimulatedModem
from vessels.models import Vessel

from .rig import CONTROL, FAST_SIM, authorise, wait_for

pytestmark = [pytest.mark.slow, pytest.mark.django_db(transaction=True)]

ROOT = Path(__file__).resolve().parents[3]
PAYLOAD = Address(0x00, 0x01)


def database_url() -> str:
    """The test database, for a child process."""
    settings = connection.settings_dict
    if connection.vendor == "sqlite":
        return f"sqlite:///{Path(str(settings['NAME'])).resolve()}"
    user, host, port = settings["USER"], settings["HOST"], settings["PORT"]
    return f"postgres://{user}@{host}:{port}/{settings['NAME']}"


@contextmanager
def plumbing() -> Iterator[tuple[PtyPort, SimulatedModem, ModemServer]]:
    cc_port = PtyPort(timeout=0.01)
    modem = SimulatedModem()
    server = ModemServer(modem, "pty").start()
    try:
        yield cc_port, modem, server
    finally:
        server.stop()
        cc_port.close()


def start_bridge(
    glider: Vessel, cc_port: PtyPort, server: ModemServer, **extra: str
) -> subprocess.Popen:
    env = {
        **os.environ,
        "DATABASE_URL": database_url(),
        "WG_VESSEL": glider.slug,
        "WG_LEVEL2_PORT": cc_port.name,
        "WG_MODEM_PORT": server.url,
        "WG_POLL_PERIOD_S": "1",
        "WG_REPLY_WINDOW_S": "60",
        "WG_RESULT_TIMEOUT_S": "60",
        "WG_TICK_S": "0.1",
        "WG_RECONNECT_DELAY_S": "0.1",
        **extra,
    }
    return subprocess.Popen(
        [sys.executable, "manage.py", "run_wg_bridge"],
        cwd=ROOT,
        env=env,
        # A file, not a pipe: a pipe nobody reads would block the bridge once full.
        stdout=tempfile.TemporaryFile(),
        stderr=subprocess.STDOUT,
    )


def kill(process: subprocess.Popen) -> None:
    process.send_signal(signal.SIGKILL)
    process.wait(10)


def stop(process: subprocess.Popen) -> None:
    """SIGTERM: the bridge stops its threads and exits 0."""
    process.send_signal(signal.SIGTERM)
    assert process.wait(20) == 0


def flagged_status(link: SerialLink, tid: int) -> bool:
    """One status request by hand; whether the reply flags a queued message (§8.4)."""
    request = Frame.make(
        MessageType.REQUEST_STATUS, bytes(StatusRequest()), tid=tid, dest=PAYLOAD, src=CC_MAIN
    )
    link.send(bytes(request))
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        reply = link.receive(1.0)
        if reply is not None and reply.tid == tid:
            return StatusReply.from_bytes(reply.body).block.queued
    raise AssertionError("no status reply")


def sms_in(glider: Vessel, modem: SimulatedModem, text: str) -> None:
    modem.inject(CONTROL, text)
    assert wait_for(lambda: Command.objects.filter(vessel=glider).exists(), 20)


def test_killed_after_the_flag_the_command_is_handed_over_once_after_restart(
    glider: Vessel,
) -> None:
    authorise(glider)
    with plumbing() as (cc_port, modem, server):
        bridge = start_bridge(glider, cc_port, server)
        sms_in(glider, modem, "#FHEAD 230")
        link = SerialLink(cc_port)
        assert wait_for(lambda: flagged_status(link, 0x0100), 20)
        kill(bridge)  # between the flag and the request queued
        command = Command.objects.get(vessel=glider)
        assert command.status == Status.QUEUED
        bridge = start_bridge(glider, cc_port, server)
        sim = CcSimulator(SerialLink(cc_port), SimConfig(**FAST_SIM), VirtualClock())  # type: ignore[arg-type]
        assert wait_for(sim.enumerate, 20)
        sim.poll_once()
        assert wait_for(lambda: modem.sent, 20)
        sim.poll_once()  # nothing more to hand over
        stop(bridge)
    assert len(sim.stats.commands) == 1
    command.refresh_from_db()
    assert command.status == Status.DONE
    assert [s.text for s in modem.sent] == ["#FHEAD 230 OK"]


def test_killed_between_the_handover_and_the_ack_nothing_is_handed_over_twice(
    glider: Vessel,
) -> None:
    authorise(glider)
    with plumbing() as (cc_port, modem, server):
        bridge = start_bridge(glider, cc_port, server)
        sms_in(glider, modem, "#FHEAD 230")
        sim = CcSimulator(
            SerialLink(cc_port),
            SimConfig(**FAST_SIM, send_results=False),  # type: ignore[arg-type]
            VirtualClock(),
        )
        assert wait_for(sim.enumerate, 20)
        sim.poll_once()
        assert len(sim.stats.commands) == 1
        command = Command.objects.get(vessel=glider)
        assert command.status == Status.SENT
        kill(bridge)  # the C&C has the command; its ACK has not come
        bridge = start_bridge(glider, cc_port, server)
        assert wait_for(sim.enumerate, 20)
        sim.poll_once()  # the command in flight is not offered again
        # The C&C's ACK, late (§8.6: 0x8041 from the C&C main task, no reference).
        ack = Frame.make(
            MessageType.ACK_NAK_QUEUED,
            bytes(AckNakQueued(0)),
            tid=0x0200,
            dest=PAYLOAD,
            src=CC_MAIN,
            no_ack=True,
        )
        sim.link.send(bytes(ack))
        assert wait_for(lambda: modem.sent, 20)
        sim.poll_once()
        stop(bridge)
    assert len(sim.stats.commands) == 1
    command.refresh_from_db()
    assert command.status == Status.DONE
    assert [s.text for s in modem.sent] == ["#FHEAD 230 OK"]
    reply = SmsMessage.objects.get(direction=Direction.OUT)
    assert reply.status == SendStatus.SENT


def test_under_systemd_it_says_ready_and_stopping(glider: Vessel, tmp_path: Path) -> None:
    address = str(tmp_path / "notify")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
    sock.bind(address)
    sock.settimeout(20)
    with plumbing() as (cc_port, _modem, server):
        bridge = start_bridge(glider, cc_port, server, NOTIFY_SOCKET=address)
        try:
            assert sock.recv(1024).startswith(b"READY=1")
        finally:
            stop(bridge)
        assert sock.recv(1024) == b"STOPPING=1"
    sock.close()
