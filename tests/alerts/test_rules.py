"""The rule kinds' verdicts and their hysteresis, as pure functions (alerts/rules.py)."""

from __future__ import annotations

import math

from hypothesis import example, given
from hypothesis import strategies as st

from alerts import rules as R
from edge_client.contract.fence import contains

volts = st.floats(min_value=9.0, max_value=14.0, allow_nan=False)


def episodes(active: bool, verdicts: list[R.Verdict]) -> int:
    return R.run(active, verdicts)[1].count("open")


def crossings_down(values: list[float], limit: float, clear: float) -> int:
    """How many times the values go below ``limit`` after having been above ``clear`` (or at
    the start): the episodes a person would count."""
    count, armed = 0, True
    for v in values:
        if armed and v < limit:
            count, armed = count + 1, False
        elif v > clear:
            armed = True
    return count


@given(st.lists(volts, max_size=200), st.floats(min_value=10.0, max_value=13.0))
@example([11.49, 11.51, 11.49, 11.55, 11.49, 11.69], 11.5)  # hovering at the limit: one episode
def test_battery_opens_once_per_episode(values: list[float], threshold: float) -> None:
    verdicts = [R.battery(v, threshold) for v in values]
    opened = episodes(False, verdicts)
    assert opened == crossings_down(values, threshold, threshold + R.BATTERY_MARGIN_V)
    # Never two opens without a resolve between them.
    _, transitions = R.run(False, verdicts)
    assert all(a != b for a, b in zip(transitions, transitions[1:], strict=False))


def test_battery_hovering_at_the_limit_opens_one_alert() -> None:
    values = [11.6, 11.49, 11.52, 11.48, 11.6, 11.45, 11.69]
    _, transitions = R.run(False, [R.battery(v, 11.5) for v in values])
    assert transitions == ["open"]
    _, transitions = R.run(False, [R.battery(v, 11.5) for v in [*values, 11.71]])
    assert transitions == ["open", "resolve"]


def test_battery_clears_above_the_rules_own_level_when_it_gives_one() -> None:
    assert R.battery(11.9, 11.5, clear_above=12.0) is R.KEEP
    assert R.battery(12.1, 11.5, clear_above=12.0) is R.CLEARS


def test_a_missing_or_broken_value_keeps_the_state() -> None:
    for value in (None, math.nan, math.inf, True, "12"):
        assert R.battery(value, 11.5) is R.KEEP  # type: ignore[arg-type]
        assert R.reading(value, R.Limits(0, 70)) is R.KEEP


def test_reading_limits_default_to_the_sensor_channels() -> None:
    assert R.reading_limits(None, 70, 0, 100) == R.Limits(0, 70)
    assert R.reading_limits(None, None, 0, 100) == R.Limits(0, 100)
    assert not R.reading_limits(None, None, None, None).usable


def test_hull_humidity_rising_opens_and_clears_with_a_margin_of_the_range() -> None:
    limits = R.Limits(0, 70)  # 2 % of 70: clears at 68.6 or below
    assert R.reading(71, limits) is R.HOLDS
    assert R.reading(69, limits) is R.KEEP
    assert R.reading(68.5, limits) is R.CLEARS
    assert R.reading(-1, limits) is R.HOLDS


@given(
    st.lists(st.floats(min_value=-10, max_value=110, allow_nan=False), max_size=200),
    st.floats(min_value=0, max_value=50),
    st.floats(min_value=60, max_value=100),
)
def test_a_reading_never_opens_twice_without_clearing(
    values: list[float], lo: float, hi: float
) -> None:
    limits = R.Limits(lo, hi)
    active, transitions = R.run(False, [R.reading(v, limits) for v in values])
    assert transitions == ["open", "resolve"] * (len(transitions) // 2) + (
        ["open"] if len(transitions) % 2 else []
    )
    # Each open needs a value outside, each resolve a value well inside.
    assert transitions.count("open") <= sum(1 for v in values if v < lo or v > hi)
    assert active == (len(transitions) % 2 == 1)


def test_overdue_scales_with_the_vessels_own_period() -> None:
    boat, glider = R.overdue_limit_s(10, 3), R.overdue_limit_s(600, 3)
    assert (boat, glider) == (30, 1800)
    assert R.overdue(31, boat) is R.HOLDS
    assert R.overdue(31, glider) is R.CLEARS
    assert R.overdue(None, boat) is R.KEEP  # never seen: nothing to be late for
    assert R.overdue_limit_s(10, None) == 10 * R.DEFAULT_OVERDUE_PERIODS


def test_endurance_clears_well_above_the_threshold() -> None:
    assert R.endurance(5, 12) is R.HOLDS
    assert R.endurance(14, 12) is R.KEEP
    assert R.endurance(15.1, 12) is R.CLEARS
    assert R.endurance(math.inf, 12) is R.CLEARS
    assert R.endurance(None, 12) is R.KEEP


SQUARE = {"inclusion": True, "polygon": [[0, 0], [0, 0.01], [0.01, 0.01], [0.01, 0]]}


def inside_square(lat: float, lon: float) -> bool:
    return contains(SQUARE, lat, lon)


def test_a_fence_opens_outside_and_clears_only_well_inside() -> None:
    assert R.fence(0.02, 0.005, True, inside_square) is R.HOLDS
    assert R.fence(0.0099, 0.005, True, inside_square) is R.KEEP  # 11 m from the line
    assert R.fence(0.005, 0.005, True, inside_square) is R.CLEARS
    # The same square as an exclusion zone: inside breaks it.
    assert R.fence(0.005, 0.005, False, inside_square) is R.HOLDS
    assert R.fence(0.02, 0.005, False, inside_square) is R.CLEARS


@given(st.lists(st.floats(min_value=0.00985, max_value=0.01015), max_size=100))
def test_a_boat_sailing_along_the_fence_line_opens_once(lats: list[float]) -> None:
    verdicts = [R.fence(lat, 0.005, True, inside_square) for lat in lats]
    # Within 17 m of the line (0.00015 degrees) it never clears, so at most one episode.
    assert episodes(False, verdicts) <= 1


def test_offset_wraps_at_the_antimeridian() -> None:
    lat, lon = R.offset(0.0, 179.9999, 90, 100)
    assert -180 <= lon < -179.99


def test_a_command_opens_on_failed_or_expired_only() -> None:
    assert R.command("failed") is R.HOLDS
    assert R.command("expired") is R.HOLDS
    assert R.command("done") is R.KEEP


def test_a_clear_fence_skips_the_probes() -> None:
    asked = []

    def counting(lat: float, lon: float) -> bool:
        asked.append((lat, lon))
        return inside_square(lat, lon)

    assert R.fence(0.005, 0.005, True, counting, need_clear=False) is R.KEEP
    assert len(asked) == 1
    assert R.fence(0.005, 0.005, True, counting) is R.CLEARS
    assert len(asked) == 1 + 1 + len(R.FENCE_PROBE_BEARINGS)
