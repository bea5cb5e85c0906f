"""Through real serial plumbing: the payload runner against the C&C simulator.

References: §9–§10 (polling, retries), §16 (simulator duties) of docs/level2.md.
The soak test runs an hour of protocol time with a virtual clock: waiting for the next poll
costs nothing, while every byte still crosses a pseudo-terminal pair and the runner's read loop.
"""

from __future__ import annotations

import random
import select
import socket
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass

import pytest

from sms.level2.bodies import Enumerate
from sms.level2.codec import BROADCAST, CC_MAIN, Frame, MessageType
from sms.level2.payload import MemoryCommandSource, PayloadConfig, PayloadMachine
from sms.level2.runner import PayloadRunner, PtyPort, SerialLink, open_port
from sms.level2.simulator import FAULTS, CcSimulator, SimConfig, VirtualClock, cycle_codes

HOUR_S = 3600.0
SOAK_PERIOD_S = 5.0  # a fast poll period: 720 polls in the simulated hour
FAST = {"reply_wait_s": 2.0, "silence_wait_s": 0.02, "retry_interval_s": 2.0}


@dataclass
class Running:
    runner: PayloadRunner
    source: MemoryCommandSource
    thread: threading.Thread
    errors: list[BaseException]


def start_runner(url: str, port_factory=open_port, **config: object) -> Running:  # type: ignore[no-untyped-def]
    source = MemoryCommandSource()
    machine = PayloadMachine(PayloadConfig(**config), source=source)  # type: ignore[arg-type]
    runner = PayloadRunner(url, machine, reconnect_delay_s=0.05, port_factory=port_factory)
    errors: list[BaseException] = []

    def target() -> None:
        try:
            runner.run()
        except BaseException as exc:  # noqa: BLE001 - the test asserts none escaped
            errors.append(exc)

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    return Running(runner, source, thread, errors)


def wait_for(condition, timeout_s: float = 5.0) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def stop(running: Running) -> None:
    running.runner.stop()
    running.thread.join(5)
    assert not running.thread.is_alive()
    assert running.errors == []


@pytest.fixture
def pty_payload() -> Iterator[tuple[PtyPort, Running]]:
    pty = PtyPort(timeout=0.01)
    running = start_runner(pty.name, poll_period_s=20)
    assert running.runner.connected.wait(5)
    yield pty, running
    stop(running)
    pty.close()


@pytest.mark.slow
def test_an_hour_of_polling_with_faults_through_a_pty(pty_payload) -> None:  # type: ignore[no-untyped-def]
    pty, running = pty_payload
    source = running.source
    config = SimConfig(
        period_s=SOAK_PERIOD_S,
        faults=FAULTS,
        fault_rate=0.25,
        seed=4,
        ack_policy=cycle_codes,
        **FAST,  # type: ignore[arg-type]
    )
    sim = CcSimulator(SerialLink(pty), config, VirtualClock())
    rng = random.Random(7)
    added: list[str] = []

    def on_tick(_elapsed: float) -> None:
        if rng.random() < 0.15:  # now and then an operator queues one to three commands
            for _ in range(rng.randrange(1, 4)):
                added.append(source.add(f"fhead {len(added)}").ident)

    stats = sim.run(HOUR_S, on_tick=on_tick)

    assert stats.polls == pytest.approx(HOUR_S / SOAK_PERIOD_S, abs=3)
    assert set(stats.faults) == set(FAULTS), "every fault was injected"
    assert running.runner.frame_errors >= stats.faults["bad_crc"] + stats.faults["bad_length"]
    # every valid request answered, nothing answered that should not be, retries identical
    assert stats.unanswered == [] and stats.unexpected_replies == []
    assert stats.duplicate_mismatches == 0 and stats.answered == stats.valid_attempts
    # every command handed over exactly once, in order, and its result recorded
    assert len(added) > 100
    assert source.handed_over == added and source.pending_count() == 0
    headings = [int.from_bytes(p.params[3:5], "little") for p in stats.commands]
    assert headings == list(range(len(added)))
    assert len(set(stats.command_tids)) == len(added)
    assert sorted(source.results) == sorted(added)
    codes = {source.results[ident].code for ident in added}
    assert codes == {0, 1, 2, 3, 4}
    assert running.runner.machine.awaiting_result == []


def test_split_bytes_and_ff_runs_are_answered(pty_payload) -> None:  # type: ignore[no-untyped-def]
    pty, _running = pty_payload
    config = SimConfig(period_s=1, faults=("split", "ff_run"), fault_rate=1.0, **FAST)  # type: ignore[arg-type]
    sim = CcSimulator(SerialLink(pty), config, VirtualClock())
    stats = sim.run(20)
    assert stats.enumerated and stats.polls >= 18
    assert stats.answered == stats.valid_attempts == stats.attempts


def test_loop_url_carries_frames_back() -> None:
    port = open_port("loop://")
    link = SerialLink(port)
    frame = Frame.make(
        MessageType.ENUMERATE, bytes(Enumerate()), tid=0x7E7D, dest=BROADCAST, src=CC_MAIN
    )
    link.send(bytes(frame), split=True)
    assert link.receive(1.0) == frame
    port.close()


class SocketPort:
    """The C&C end of a TCP connection with the pyserial calls SerialLink uses."""

    def __init__(self, conn: socket.socket) -> None:
        self.conn = conn
        self.timeout = 0.01

    @property
    def in_waiting(self) -> int:
        return 4096 if select.select([self.conn], [], [], 0)[0] else 0

    def read(self, size: int = 1) -> bytes:
        if not select.select([self.conn], [], [], self.timeout)[0]:
            return b""
        return self.conn.recv(size)

    def write(self, data: bytes) -> None:
        self.conn.sendall(data)

    def flush(self) -> None:
        pass


def test_the_runner_survives_a_port_that_disappears_and_comes_back() -> None:
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    host, port = probe.getsockname()
    probe.close()
    # The port is not there yet: the runner keeps trying.
    running = start_runner(f"socket://{host}:{port}")
    try:
        assert wait_for(lambda: running.runner.port_failures >= 2)
        listener = socket.create_server((host, port))
        listener.settimeout(5)
        conn, _ = listener.accept()
        sim = CcSimulator(SerialLink(SocketPort(conn)), SimConfig(**FAST), VirtualClock())  # type: ignore[arg-type]
        assert sim.enumerate()
        sim.poll_once()
        assert sim.stats.answered == 2

        running.source.add("fhead 230")
        conn.close()  # the port disappears…
        conn, _ = listener.accept()  # …and comes back: the runner reopened it
        sim = CcSimulator(SerialLink(SocketPort(conn)), SimConfig(**FAST), VirtualClock())  # type: ignore[arg-type]
        assert sim.enumerate()
        sim.poll_once()
        assert [p.value for p in sim.stats.commands] == [0x0008]
        assert running.source.handed_over == ["cmd-1"]
        assert running.runner.opens == 2
        conn.close()
        listener.close()
    finally:
        stop(running)
