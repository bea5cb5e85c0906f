"""The bridge's housekeeping tick (issue 17 item 5): a step that keeps failing is retried ever
less often, its traceback logged once, while the other steps carry on every tick."""

from __future__ import annotations

import logging

import pytest

from sms.bridge import process
from sms.bridge.process import Bridge, BridgeConfig
from vessels.models import Vessel


@pytest.fixture
def bridge(glider: Vessel) -> Bridge:
    # Built, never run: no port is opened until the threads start.
    config = BridgeConfig(vessel=glider.slug, level2_port="loop://", modem_port="loop://")
    return Bridge(config, vessel=glider)


def test_a_failing_step_backs_off_and_the_others_carry_on(
    bridge: Bridge, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    now = [0.0]
    bridge.clock = lambda: now[0]
    calls = {"fixes": 0, "command results": 0}

    def broken_flush() -> None:
        calls["fixes"] += 1
        raise ValueError("a fix the recorder cannot take")

    def flush_results() -> None:
        calls["command results"] += 1

    monkeypatch.setattr(bridge.fixes, "flush_if_due", broken_flush)
    monkeypatch.setattr(bridge.source, "flush_results", flush_results)
    caplog.set_level(logging.INFO, logger=process.__name__)
    for tick in range(60):  # a minute of one-second ticks
        now[0] = float(tick)
        assert bridge.do_one_housekeeping()  # no database error
    assert calls["command results"] == 60  # the healthy step ran every tick
    # Tried at 0, 1, 3, 7, 15, 31 s (waits of 1, 2, 4, 8, 16 s), not 60 times.
    assert calls["fixes"] == 6
    lines = [r for r in caplog.records if "fixes" in r.getMessage()]
    assert len(lines) == 6
    assert [r for r in lines if r.exc_info] == lines[:1]  # one traceback, then one line each
    assert lines[0].levelno == logging.ERROR
    assert "6 in a row" in lines[-1].getMessage() and "next try in 30.0 s" in lines[-1].getMessage()
    assert bridge.step_health["fixes"].retry_at == 31 + process.HOUSEKEEPING_RETRY_MAX_S

    monkeypatch.setattr(bridge.fixes, "flush_if_due", lambda: None)  # mended
    now[0] = 61.0
    bridge.do_one_housekeeping()
    assert bridge.step_health["fixes"].failures == 0
    assert "working again after 6 failure(s)" in caplog.records[-1].getMessage()


def test_the_retry_wait_doubles_from_one_tick_up_to_the_cap() -> None:
    waits = [process.housekeeping_retry_s(0.5, n) for n in range(1, 10)]
    assert waits == [0.5, 1, 2, 4, 8, 16, 30, 30, 30]
    assert not hasattr(process, "PeriodicTask")
