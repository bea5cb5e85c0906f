"""The command lines ``python -m edge_client.sbd`` (send, receive, signal) and
``python -m edge_client.sbd.simulator``, against the simulator on a real pty."""

from __future__ import annotations

import io
import os
import select
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from edge_client.sbd.cli import main
from edge_client.sbd.simulator import SbdModemServer, SimulatedSbdModem, control

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def server() -> Iterator[SbdModemServer]:
    with SbdModemServer(SimulatedSbdModem()) as server:
        yield server


def run(*argv: str) -> tuple[int, str]:
    out = io.StringIO()
    status = main(list(argv), out)
    return status, out.getvalue()


def test_send_a_file(server: SbdModemServer, tmp_path: Path) -> None:
    payload = tmp_path / "batch.bin"
    payload.write_bytes(b"\x01\x02fixes")
    server.modem.queue_mt(b"#FHEAD 230", ring=False)
    status, out = run("send", str(payload), "--port", server.url)
    assert status == 0, out
    assert "sent 7 bytes: momsn 0" in out
    assert "'#FHEAD 230'" in out and "(0 more queued)" in out
    assert server.modem.delivered == [b"\x01\x02fixes"]


def test_a_file_too_big_is_refused(server: SbdModemServer, tmp_path: Path) -> None:
    payload = tmp_path / "big.bin"
    payload.write_bytes(b"x" * 341)
    status, out = run("send", str(payload), "--port", server.url)
    assert status == 2 and "error (permanent)" in out and "340" in out
    assert server.modem.commands == []


def test_receive_fetches_every_queued_message(server: SbdModemServer) -> None:
    def arrive() -> None:  # once the CLI has turned ring alerts on and waits
        for text in (b"one", b"two", b"three"):
            server.modem.queue_mt(text)

    timer = threading.Timer(0.5, arrive)
    timer.start()
    status, out = run("receive", "--port", server.url, "--wait-ring", "5")
    timer.join()
    assert status == 0, out
    assert out.splitlines()[0] == "ring"
    assert [line.split("bytes: ")[1].split()[0] for line in out.splitlines()[1:]] == [
        b"one".hex(),
        b"two".hex(),
        b"three".hex(),
    ]


def test_receive_with_nothing_waiting(server: SbdModemServer) -> None:
    status, out = run("receive", "--port", server.url)
    assert (status, out.strip()) == (0, "no message waiting (momsn 0)")


def test_signal_and_a_failing_network(server: SbdModemServer, tmp_path: Path) -> None:
    server.modem.signal = 3
    assert run("signal", "--port", server.url) == (0, "signal: 3 bars\n")
    server.modem.network = False
    payload = tmp_path / "m.bin"
    payload.write_bytes(b"m")
    status, out = run("send", str(payload), "--port", server.url, "--attempts", "1")
    assert status == 1 and "error (temporary)" in out and "32" in out


def test_the_simulators_operator_lines() -> None:
    modem = SimulatedSbdModem()
    assert control(modem, "mt hello") == "ok: mt hello"
    assert control(modem, "mthex 00ff") == "ok: mthex 00ff"
    assert modem.mt_queue == [b"hello", b"\x00\xff"]
    control(modem, "network off")
    control(modem, "fail 35")
    control(modem, "signal 9")
    assert (modem.network, modem.fail_codes, modem.signal) == (False, [35], 5)
    assert control(modem, "mthex zz").startswith("bad value")
    assert control(modem, "launch").startswith("unknown")


def test_the_simulator_runs_on_its_own_and_prints_its_pty(tmp_path: Path) -> None:
    sim = subprocess.Popen(
        [sys.executable, "-m", "edge_client.sbd.simulator", "--duration", "20"],
        cwd=ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert sim.stdout is not None and sim.stdin is not None
        url = sim.stdout.readline().strip()
        assert url.startswith("/dev/") and os.path.exists(url)
        sim.stdin.write("mt from the shore\n")
        sim.stdin.flush()
        assert sim.stdout.readline().strip() == "ok: mt from the shore"
        payload = tmp_path / "m.bin"
        payload.write_bytes(b"from the boat")
        status, out = run("send", str(payload), "--port", url)
        assert status == 0, out
        assert "'from the shore'" in out
        deadline = time.monotonic() + 5
        seen = ""
        while "from the boat" not in seen and time.monotonic() < deadline:
            if select.select([sim.stdout], [], [], 0.2)[0]:
                seen += sim.stdout.readline()
        assert "MO momsn=0 b'from the boat'" in seen
    finally:
        sim.terminate()
        sim.wait(10)
