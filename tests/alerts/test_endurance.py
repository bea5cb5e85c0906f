"""Battery endurance from day-over-day hourly means (alerts/endurance.py)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from alerts.endurance import HOUR_S, endurance_hours, hourly_means_from_channels

NOW = 1_800_000_000  # a whole hour: 1_800_000_000 / 3600 = 500_000


def solar_day(hours: int, *, start_v: float, drain_v_per_h: float, swing_v: float = 0.8):
    """Hourly means of a solar vessel: a linear drain under a daily charge hump (daytime only,
    not a sinusoid), the last whole hour ending at NOW."""
    means = {}
    for k in range(hours):
        start = NOW - HOUR_S * (hours - k)
        hour_of_day = (start // HOUR_S) % 24
        sun = max(0.0, math.sin(math.pi * (hour_of_day - 6) / 12))  # 06:00-18:00
        means[start] = start_v - drain_v_per_h * k + swing_v * sun
    return means


def test_a_solar_vessel_draining_slowly_is_judged_by_its_trend_not_its_mornings() -> None:
    means = solar_day(48, start_v=12.8, drain_v_per_h=0.01)
    hours = endurance_hours(means, empty_v=11.5, now_s=NOW + 600)
    # The trough of the last day (night, no sun): 12.8 - 0.01 * 47 at most
    trough = min(v for t, v in means.items() if t >= NOW - 24 * HOUR_S)
    assert hours == pytest.approx((trough - 11.5) / 0.01, rel=1e-6)


@given(st.floats(min_value=0.001, max_value=0.05), st.floats(min_value=0.0, max_value=2.0))
def test_the_daily_swing_cancels_whatever_its_size(drain: float, swing: float) -> None:
    means = solar_day(48, start_v=13.5, drain_v_per_h=drain, swing_v=swing)
    hours = endurance_hours(means, empty_v=10.0, now_s=NOW + 1)
    trough = min(v for t, v in means.items() if t >= NOW - 24 * HOUR_S)
    assert hours == pytest.approx(max(0.0, (trough - 10.0) / drain), rel=1e-6)


def test_a_battery_holding_day_over_day_has_no_end() -> None:
    means = solar_day(48, start_v=12.8, drain_v_per_h=0.0)
    assert endurance_hours(means, empty_v=11.5, now_s=NOW) == math.inf


def test_a_trough_below_empty_is_zero_hours() -> None:
    means = solar_day(48, start_v=11.6, drain_v_per_h=0.01)
    assert endurance_hours(means, empty_v=11.5, now_s=NOW) == 0.0


def test_no_estimate_without_a_day_of_pairs() -> None:
    means = solar_day(30, start_v=12.8, drain_v_per_h=0.01)  # 6 pairs: just enough
    assert endurance_hours(means, empty_v=11.5, now_s=NOW) is not None
    means = solar_day(29, start_v=12.8, drain_v_per_h=0.01)
    assert endurance_hours(means, empty_v=11.5, now_s=NOW) is None
    assert endurance_hours({}, empty_v=11.5, now_s=NOW) is None


def test_the_hour_in_progress_is_not_used() -> None:
    means = solar_day(48, start_v=12.8, drain_v_per_h=0.01)
    with_partial = {**means, NOW: 5.0}  # a partial hour's odd mean
    assert endurance_hours(with_partial, empty_v=11.5, now_s=NOW + 60) == endurance_hours(
        means, empty_v=11.5, now_s=NOW + 60
    )


def test_hourly_means_come_from_the_overviews_battery_channel() -> None:
    buckets = [(0, {"": [11.0, 13.0, 24.0, 2]}), (3600, {"leak1": [0, 0, 0, 1]}), (7200, {})]
    assert hourly_means_from_channels(buckets) == {0: 12.0}
