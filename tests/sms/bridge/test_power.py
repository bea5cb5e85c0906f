"""A power-down notice: logged with its frame, flush, then the command (sms/bridge/power.py)."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import pytest

from sms.bridge.power import handle_power_down, parse_command

FRAME = bytes.fromhex("7e0e00ffff0000302030000103")  # the bytes need not parse: they are logged


def test_with_no_command_it_logs_the_frame_and_flushes(caplog: pytest.LogCaptureFixture) -> None:
    done: list[str] = []
    caplog.set_level(logging.WARNING, "sms.bridge.power")
    outcome = handle_power_down(
        FRAME,
        flush=[("fixes", lambda: done.append("fixes")), ("results", lambda: done.append("r"))],
    )
    assert done == ["fixes", "r"] and outcome.flushed == ["fixes", "results"]
    assert outcome.returncode is None and outcome.error == ""
    assert "7e 0e 00 ff ff" in caplog.text and "log only" in caplog.text


@pytest.mark.slow
def test_it_runs_the_command_after_flushing_even_if_a_flush_fails(tmp_path: Path) -> None:
    marker = tmp_path / "powered-down"
    order: list[str] = []

    def broken() -> None:
        raise RuntimeError("disk full")

    outcome = handle_power_down(
        FRAME,
        command=["touch", str(marker)],
        flush=[("broken", broken), ("fixes", lambda: order.append(str(marker.exists())))],
    )
    assert marker.exists() and order == ["False"], "flushed before the command ran"
    assert outcome.returncode == 0
    assert outcome.flush_errors == ["broken: disk full"] and outcome.flushed == ["fixes"]


@pytest.mark.slow
def test_a_command_that_hangs_fails_or_is_missing_never_raises(tmp_path: Path) -> None:
    slow = handle_power_down(
        FRAME, command=[sys.executable, "-c", "import time; time.sleep(30)"], timeout_s=0.5
    )
    assert slow.returncode is None and "timed out" in slow.error
    failing = handle_power_down(FRAME, command=["false"])
    assert failing.returncode == 1
    missing = handle_power_down(FRAME, command=[str(tmp_path / "no-such-program")])
    assert missing.returncode is None and missing.error


def test_a_configured_command_line_becomes_argv() -> None:
    assert parse_command("sudo systemctl poweroff") == ["sudo", "systemctl", "poweroff"]
    assert parse_command("  ") is None
    assert parse_command("touch '/tmp/a b'") == ["touch", "/tmp/a b"]
