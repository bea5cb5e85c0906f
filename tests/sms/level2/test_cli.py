"""``python -m sms.level2`` (issue 4 §6): decode, payload and cc."""

from __future__ import annotations

import io
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from sms.level2.cli import main

from .conftest import DATA
from .test_codec import APPENDIX_A

ROOT = Path(__file__).resolve().parents[3]


def run_main(*argv: str) -> tuple[int, list[str]]:
    out = io.StringIO()
    status = main(list(argv), out=out)
    return status, out.getvalue().splitlines()


def test_decode_a_capture_prints_every_frame_and_the_counts() -> None:
    status, lines = run_main("decode", "--cfa", str(DATA / "Responses.cfa"))
    assert status == 0
    assert lines[-1] == "summary: good=12 bad=1 dropped_bytes=60"
    assert sum("crc=ok" in line for line in lines) == 12
    [bad] = [line for line in lines if "crc=bad" in line]
    assert bad.startswith("PAY->C&C ACK 00/17->00/00 tid=0x0017")


def test_decode_hex_text(tmp_path: Path) -> None:
    text = "\n".join([APPENDIX_A["enumerate"], "ff ff", APPENDIX_A["enum_reply"].lower()])
    (tmp_path / "frames.txt").write_text(text)
    status, lines = run_main("decode", "--hex", str(tmp_path / "frames.txt"))
    assert status == 0
    assert lines[0] == "ENUMERATE 00/00->FF/FF tid=0x0017 protocols=1 formats=1 crc=ok"
    assert (
        lines[1].startswith("ACK 00/01->00/00 tid=0x0017 enum-reply") and "'Full PIB'" in lines[1]
    )
    assert lines[-1] == "summary: good=2 bad=0 dropped_bytes=2"


def test_decode_refuses_odd_hex(tmp_path: Path) -> None:
    (tmp_path / "odd.txt").write_text("7E 1")
    assert run_main("decode", "--hex", str(tmp_path / "odd.txt"))[0] == 2


def test_decode_raw_bytes_reports_truncated_and_bad_frames(tmp_path: Path) -> None:
    enumerate_ = bytes.fromhex(APPENDIX_A["enumerate"])
    broken = bytearray(enumerate_)
    broken[-1] ^= 1
    (tmp_path / "raw.bin").write_bytes(enumerate_[:6] + bytes(broken) + enumerate_)
    status, lines = run_main("decode", str(tmp_path / "raw.bin"))
    assert status == 0
    assert lines[0].startswith("bad frame: truncated frame")
    assert lines[1] == "ENUMERATE 00/00->FF/FF tid=0x0017 L=16 crc=bad"
    assert lines[2].endswith("crc=ok")
    assert lines[-1] == "summary: good=1 bad=2 dropped_bytes=23"


def test_payload_refuses_a_command_the_table_refuses() -> None:
    status, lines = run_main("payload", "--port", "loop://", "--command", "fseq 1 1 4")
    assert status == 2 and "provisional entry not enabled" in lines[-1]


@pytest.mark.slow
def test_payload_and_cc_talk_over_a_pty() -> None:
    python = [sys.executable, "-m", "sms.level2"]
    payload = subprocess.Popen(
        [*python, "payload", "--port", "pty", "--duration", "30"]
        + ["--command", "fhead 230", "--command", "light on"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert payload.stdout is not None
    lines = [payload.stdout.readline() for _ in range(3)]
    device = lines[2].split()[-1]
    assert lines[2].startswith("pty:") and device.startswith("/dev/")
    cc = subprocess.run(
        [*python, "cc", "--port", device, "--period", "0.3", "--duration", "2"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=30,
    )
    payload.send_signal(signal.SIGTERM)  # stops the runner; the results are printed
    rest, _ = payload.communicate(timeout=30)
    assert payload.returncode == 0
    assert cc.returncode == 0, cc.stdout + cc.stderr
    assert "C&C -> ENUMERATE" in cc.stdout and "queued-reply MORE command value=0x0008" in cc.stdout
    summary = cc.stdout.splitlines()[-1]
    assert "unanswered=0" in summary and "commands=2" in summary
    assert "result cmd-1: code=0 (accepted)" in rest
    assert "result cmd-2: code=0 (accepted)" in rest
