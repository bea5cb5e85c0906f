"""bench.server's interleaved single-post rounds: the order and the combined figures."""

from __future__ import annotations

import pytest

from bench.server.cli import parse_args
from bench.server.phases import single_round_order
from bench.server.wrk import WrkResult, combine


def _run(ok: int, seconds: float, p50: float) -> WrkResult:
    return WrkResult(ok, seconds, ok, 0, 0, "", p50, p50, p50, p50, 1.0, 0.1)


def test_each_side_goes_first_as_often_as_second() -> None:
    order = single_round_order(4)
    assert order == ["ours", "drf", "drf", "ours", "ours", "drf", "drf", "ours"]
    firsts = order[::2]
    assert firsts.count("ours") == firsts.count("drf")


def test_rounds_combine_into_one_rate() -> None:
    both = combine([_run(100, 1.0, 2.0), _run(300, 2.0, 4.0)])
    assert both.rps == pytest.approx(400 / 3.0)
    assert both.p50_ms == pytest.approx((100 * 2.0 + 300 * 4.0) / 400)
    assert both.max_ms == 4.0


def test_single_only_and_rounds_options() -> None:
    opts = parse_args(["--quick", "--single-only", "--rounds", "4"])
    assert (opts.single_only, opts.rounds, opts.phase_seconds) == (True, 4, 3.0)
    with pytest.raises(SystemExit):
        parse_args(["--rounds", "0"])
