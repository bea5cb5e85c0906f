"""``python -m sms.modem sim | listen | send`` (issue 10 item 5: trying it by hand)."""

from __future__ import annotations

import io
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from sms.modem.cli import main

ROOT = Path(__file__).resolve().parents[3]


def run_main(*argv: str) -> tuple[int, list[str]]:
    out = io.StringIO()
    status = main(list(argv), out=out)
    return status, out.getvalue().splitlines()


def test_send_to_a_port_that_does_not_exist_is_a_temporary_error() -> None:
    status, lines = run_main(
        "send", "--port", "socket://127.0.0.1:1", "--to", "+614", "--text", "x"
    )
    assert status == 1 and lines[0].startswith("error (temporary): cannot open")


@pytest.mark.slow
@pytest.mark.parametrize("where", ["pty", "tcp:0"])
def test_sim_listen_and_send_talk_to_each_other(where: str) -> None:
    sim = subprocess.Popen(
        [sys.executable, "-m", "sms.modem", "sim", "--port", where, "--duration", "30"],
        cwd=ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert sim.stdin is not None and sim.stdout is not None
    try:
        first = sim.stdout.readline()
        url = first.split()[-1]
        assert first.startswith(("pty: the driver opens /dev/", "tcp: the driver opens socket://"))
        sim.stdin.write("+61400000001 #FHEAD 230\n")
        sim.stdin.flush()
        assert sim.stdout.readline().strip() == "stored at 1"

        status, lines = run_main("listen", "--port", url, "--delete", "--duration", "1")
        assert status == 0
        [line] = lines
        assert line.startswith("[1] +61400000001 ") and line.endswith("REC UNREAD: #FHEAD 230")

        status, lines = run_main(
            "send", "--port", url, "--to", "+61400000001", "--text", "#FHEAD 230 OK"
        )
        assert (status, lines) == (0, ["sent: reference 1"])
        assert sim.stdout.readline().strip() == "sent to +61400000001 (ref 1): #FHEAD 230 OK"
    finally:
        sim.send_signal(signal.SIGTERM)
        rest, _ = sim.communicate(timeout=10)
    assert sim.returncode == 0
    assert rest.strip().endswith("summary: stored=0 sent=1")
