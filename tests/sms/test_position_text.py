"""The position SMS's text (issue 20 §5): GSM-7 only, one SMS of 160 septets, for any fix."""

from __future__ import annotations

import datetime as dt

from hypothesis import example, given
from hypothesis import strategies as st

from sms.gsm7 import SMS_SEPTETS, encode, is_gsm7, septets
from sms.position_text import NAME_MAX, PositionReport, format_position

T = dt.datetime(2026, 11, 28, 11, 30, 59, tzinfo=dt.UTC)


def report(**changes: object) -> PositionReport:
    fields: dict[str, object] = {
        "time": T, "lat": 36.803, "lon": -121.788, "heading_deg": 230.4, "speed_mps": 0.6,
        "battery_v": 12.64, "name": "Wave Glider", "state": "nav FHEAD 230",
    }  # fmt: skip
    fields.update(changes)
    return PositionReport(**fields)  # type: ignore[arg-type]


def test_the_everyday_message() -> None:
    assert format_position(report()) == (
        "Wave Glider 2026-11-28 11:30 UTC 36.80300,-121.78800 hdg 230 1.2kn batt 12.6V "
        "nav FHEAD 230"
    )


def test_unknown_values_are_left_out() -> None:
    bare = report(heading_deg=None, speed_mps=None, battery_v=None, state="", name="")
    assert format_position(bare) == "2026-11-28 11:30 UTC 36.80300,-121.78800"


def test_the_time_is_utc_to_the_minute_never_rounded_up() -> None:
    sydney = dt.timezone(dt.timedelta(hours=11))
    text = format_position(report(time=dt.datetime(2026, 11, 28, 22, 59, 59, tzinfo=sydney)))
    assert "2026-11-28 11:59 UTC" in text


def test_impossible_values_are_not_shown_as_if_true() -> None:
    text = format_position(
        report(
            lat=float("nan"), lon=200.0, heading_deg=float("inf"), speed_mps=-1.0, battery_v=1e9
        )  # fmt: skip
    )
    assert "?,? " in text and "hdg" not in text and "kn" not in text and "batt" not in text
    assert "hdg 000" in format_position(report(heading_deg=359.7))
    assert " 0.00000," in format_position(report(lat=-0.000001))


def test_a_long_state_is_cut_first_and_the_name_is_cut_to_its_limit() -> None:
    text = format_position(report(name="N" * 100, state="S" * 300))
    assert septets(text) == SMS_SEPTETS
    assert text.startswith("N" * (NAME_MAX - 2) + ".. 2026-11-28")
    assert text.endswith("S..") and "batt 12.6V" in text


def test_characters_outside_gsm7_are_spelled_plainly_and_lines_joined() -> None:
    text = format_position(report(name="Łódź\nglider", state="nav “FHEAD” 230°\x1b"))
    assert text.startswith("?odz glider ") and text.endswith('nav "FHEAD" 230 deg?')
    assert is_gsm7(text)


def test_extension_characters_count_twice() -> None:
    text = format_position(report(state="€" * 200))
    assert septets(text) <= SMS_SEPTETS < len(text) * 2
    assert len(encode(text)) == septets(text)


HUGE = 10**400  # no float can hold it
names = st.text(max_size=300)
numbers = st.one_of(st.none(), st.floats(allow_nan=True, allow_infinity=True), st.integers())


@given(
    time=st.datetimes(timezones=st.one_of(st.none(), st.timezones())),
    lat=st.floats() | st.integers(),
    lon=st.floats() | st.integers(),
    heading=numbers,
    speed=numbers,
    battery=numbers,
    name=names,
    state=names,
)
@example(time=dt.datetime.max, lat=-90.0, lon=-180.0, heading=359.4, speed=51.4, battery=99.94,
         name="€" * 300, state="€" * 300)  # fmt: skip
@example(time=dt.datetime.min.replace(tzinfo=dt.timezone(dt.timedelta(hours=23))), lat=HUGE,
         lon=-HUGE, heading=HUGE, speed=HUGE, battery=HUGE, name="", state="")  # fmt: skip
def test_any_fix_gives_one_gsm7_sms(
    time: dt.datetime,
    lat: float,
    lon: float,
    heading: float | None,
    speed: float | None,
    battery: float | None,
    name: str,
    state: str,
) -> None:
    text = format_position(
        PositionReport(time, lat, lon, heading, speed, battery, name=name, state=state)
    )
    assert is_gsm7(text)
    assert septets(text) <= SMS_SEPTETS
    assert len(encode(text)) == septets(text)  # what the modem is given, byte per septet
    assert " UTC" in text  # the time and the position are never dropped
    assert "\n" not in text and "\r" not in text
