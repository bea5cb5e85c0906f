"""The one display format (vessels.display): times, positions, speeds, readings, states."""

from __future__ import annotations

import datetime as dt
import zoneinfo

import pytest

from commands import catalog
from vessels.display import (
    STATE_CHANNELS,
    fmt_ddm,
    fmt_heading,
    fmt_number,
    fmt_position,
    fmt_reading,
    fmt_readings,
    fmt_speed,
    fmt_time,
    state_channels_config,
)


def test_a_time_is_utc_with_seconds_and_says_so() -> None:
    perth = zoneinfo.ZoneInfo("Australia/Perth")
    assert fmt_time(dt.datetime(2026, 11, 25, 22, 3, 27, 900_000, tzinfo=perth)) == (
        "2026-11-25 14:03:27 UTC"
    )
    # Two fixes five seconds apart read differently.
    base = dt.datetime(2026, 11, 25, 14, 3, 0, tzinfo=dt.UTC)
    assert fmt_time(base) != fmt_time(base + dt.timedelta(seconds=5))
    assert fmt_time(dt.datetime(2026, 1, 2, 3, 4, 5)) == "2026-01-02 03:04:05 UTC"  # naive = UTC
    assert fmt_time(None) == "–"


@pytest.mark.parametrize(
    ("lat", "lon", "decimal", "ddm"),
    [
        (-32.038, 115.3325, "-32.03800°, 115.33250°", "32°02.280′S 115°19.950′E"),
        (51.5, -0.1275, "51.50000°, -0.12750°", "51°30.000′N 0°07.650′W"),
        # 59.99999′ rounds into the next degree, never "60.000′".
        (10.9999999, 0.0, "11.00000°, 0.00000°", "11°00.000′N 0°00.000′E"),
    ],
)
def test_positions_read_in_decimal_degrees_with_the_chart_form_beside(
    lat: float, lon: float, decimal: str, ddm: str
) -> None:
    assert fmt_position(lat, lon) == decimal
    assert fmt_ddm(lat, lon) == ddm


def test_a_speed_carries_metres_per_second_and_knots() -> None:
    assert fmt_speed(1.5) == "1.5 m/s (2.9 kn)"
    assert fmt_speed(0.0) == "0.0 m/s (0.0 kn)"
    # Ties round away from zero, as the page's toFixed does (Python's format would say 0.2).
    assert fmt_speed(0.25) == "0.3 m/s (0.5 kn)"
    assert fmt_speed(None) == "–"


def test_a_heading_reads_as_three_digits() -> None:
    assert [fmt_heading(h) for h in (0.0, 5.2, 90.0, 359.4, 359.5, None)] == [
        "000°", "005°", "090°", "359°", "000°", "–"
    ]  # fmt: skip


def test_numbers_are_short() -> None:
    assert [fmt_number(v) for v in (12.4, 41.0, 41, 1234.56, 0.125, -0.001)] == [
        "12.4", "41", "41", "1234.6", "0.13", "0"
    ]  # fmt: skip


def test_the_mode_names_are_the_catalogs_rover_modes() -> None:
    states = STATE_CHANNELS["mode_number"]["states"]
    assert states == {number: name for name, number in catalog.ROVER_MODES.items()} | {
        16: "INITIALISING"
    }
    assert (states[4], states[10], states[15]) == ("HOLD", "AUTO", "GUIDED")


def test_the_boot_mode_rover_reports_is_named_though_nobody_may_ask_for_it() -> None:
    assert fmt_reading("mode_number", 16, {}) == "Mode INITIALISING"
    assert "INITIALISING" not in catalog.ROVER_MODES


def test_readings_are_labelled_and_states_named() -> None:
    channels = {
        "humidity": {"label": "humidity", "unit": "%"},
        "battery_v": {"label": "Battery", "unit": "V"},
    }
    readings = {"humidity": 41.0, "battery_v": 12.4, "armed": 0, "mode_number": 10, "x_raw": 3.5}
    assert fmt_readings(readings, channels) == [
        "Mode AUTO", "disarmed", "Battery 12.4 V", "humidity 41 %", "x_raw 3.5"
    ]  # fmt: skip
    assert fmt_reading("armed", 1.0, {}) == "armed"
    # A value the table does not name stays a number; a label from a SensorChannel row wins.
    assert fmt_reading("mode_number", 99, {"mode_number": {"label": "Autopilot"}}) == "Autopilot 99"
    assert fmt_reading("armed", 0.5, {}) == "Armed 0.5"


def test_the_page_config_of_the_state_channels_is_json_shaped() -> None:
    config = state_channels_config()
    assert config["armed"]["states"] == {"0": "disarmed", "1": "armed"}
    assert config["mode_number"]["states"]["15"] == "GUIDED"
