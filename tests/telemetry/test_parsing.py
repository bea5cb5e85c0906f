"""Fix parsing (telemetry/parsing.py): v1 records, legacy records and their time rules. Pure."""

from __future__ import annotations

import datetime as dt
import json
from typing import Any

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from telemetry.parsing import (
    LEGACY_EPOCH,
    FixData,
    FixErrors,
    legacy_time,
    parse_fix,
    parse_legacy_fix,
    parse_time,
)

NOW = dt.datetime(2026, 11, 23, 10, 0, tzinfo=dt.UTC)


def record(**overrides: Any) -> dict[str, Any]:
    base: dict[str, Any] = {"time": "2026-11-23T09:59:00Z", "lat": -31.95, "lon": 115.86}
    base.update(overrides)
    return {k: v for k, v in base.items() if v is not ...}


def errors_of(raw: Any, **kwargs: Any) -> dict[str, str]:
    with pytest.raises(FixErrors) as err:
        parse_fix(raw, now=NOW, **kwargs)
    return err.value.errors


def test_it_parses_a_full_record() -> None:
    fix = parse_fix(
        record(heading_deg=359.5, speed_mps=0, battery_v=12.6, readings={"water_temp_c": 19}),
        now=NOW,
    )
    assert fix == FixData(
        recorded_at=dt.datetime(2026, 11, 23, 9, 59, tzinfo=dt.UTC),
        lat=-31.95,
        lon=115.86,
        heading_deg=359.5,
        speed_mps=0.0,
        battery_v=12.6,
        readings={"water_temp_c": 19.0},
    )


@pytest.mark.parametrize(
    "value",
    [
        "2026-11-23T09:59:00Z",
        "2026-11-23T09:59:00+00:00",
        "2026-11-23T17:59:00+08:00",
        "2026-11-23T04:29:00-05:30",
        "2026-11-23 09:59:00Z",
        1795427940,
        1795427940.0,
    ],
)
def test_it_reads_iso_8601_with_any_offset_and_unix_seconds(value: Any) -> None:
    when = parse_time(value, now=NOW, max_future_s=300)
    assert when == dt.datetime(2026, 11, 23, 9, 59, tzinfo=dt.UTC)
    assert when.tzinfo == dt.UTC


def test_it_keeps_microseconds() -> None:
    fix = parse_fix(record(time="2026-11-23T09:59:00.123456Z"), now=NOW)
    assert fix.recorded_at.microsecond == 123456


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("2026-11-23T09:59:00", "needs a UTC offset"),
        ("2026-11-23", "needs a UTC offset"),
        ("23/11/2026 09:59", "must be ISO 8601"),
        ("2026-11-23T09:59:00Z\x00", "Null characters are not allowed"),
        ("2026-11-23T09:59:00Z\x00junk", "Null characters are not allowed"),
        ("2026-11-23T09:59:00\ud800", "Surrogate characters are not allowed"),
        ("", "must be ISO 8601"),
        (None, "must be ISO 8601"),
        (True, "must be ISO 8601"),
        ([1795427940], "must be ISO 8601"),
        (float("nan"), "must be ISO 8601"),
        (10**400, "must be ISO 8601"),
        (1e18, "is out of range"),
        (-1e18, "is out of range"),
        (0, "is before 2018-01-01"),
        ("2017-12-31T23:59:59Z", "is before 2018-01-01"),
        ("2026-11-23T10:05:01Z", "is more than 300 s in the future"),
    ],
)
def test_it_refuses_times_it_cannot_trust(value: Any, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        parse_time(value, now=NOW, max_future_s=300)


def test_the_future_allowance_is_a_parameter() -> None:
    assert parse_time("2026-11-23T10:05:00Z", now=NOW, max_future_s=300)
    with pytest.raises(ValueError):
        parse_time("2026-11-23T10:00:02Z", now=NOW, max_future_s=1)
    assert errors_of(record(time="2026-11-23T10:00:02Z"), max_future_s=1) == {
        "time": "is more than 1 s in the future (check the clock)"
    }


def test_it_names_every_problem_at_once() -> None:
    assert errors_of(
        {"lat": 91, "lon": "east", "heading_deg": -1, "readings": {"t": "x"}, "alt": 3}
    ) == {
        "alt": "unknown field (allowed: battery_v, heading_deg, lat, lon, readings, speed_mps, "
        "time)",
        "time": "is required",
        "lat": "must be between -90 and 90",
        "lon": "must be a number",
        "heading_deg": "must be between 0 and 360",
        "readings": "t must be a number",
    }


@pytest.mark.parametrize("raw", [None, [], "fix", 3, True])
def test_a_record_must_be_an_object(raw: Any) -> None:
    assert errors_of(raw) == {"non_field_errors": "each fix must be a JSON object"}


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("lat", True),
        ("lat", False),
        ("lon", "115"),
        ("lat", float("nan")),
        ("lon", float("-inf")),
        ("lat", 10**400),
        ("heading_deg", True),
        ("speed_mps", "1"),
        ("battery_v", [12]),
    ],
)
def test_bools_strings_and_non_finite_values_are_not_numbers(field: str, value: Any) -> None:
    assert errors_of(record(**{field: value})) == {field: "must be a number"}


@pytest.mark.parametrize(("lat", "lon"), [(90, 180), (-90, -180), (0, 0), (89.999999, -179.999999)])
def test_it_accepts_the_edges_of_the_globe(lat: float, lon: float) -> None:
    fix = parse_fix(record(lat=lat, lon=lon), now=NOW)
    assert (fix.lat, fix.lon) == (lat, lon)


def test_a_heading_of_360_is_north() -> None:
    assert parse_fix(record(heading_deg=360), now=NOW).heading_deg == 0.0


def test_optional_values_may_be_null_or_missing() -> None:
    fix = parse_fix(record(heading_deg=None, readings=None), now=NOW)
    assert (fix.heading_deg, fix.speed_mps, fix.battery_v, fix.readings) == (None, None, None, {})


@pytest.mark.parametrize(
    ("readings", "message"),
    [
        ([["t", 1]], "must be an object of name: number"),
        ({"": 1}, "name '' must be 1-50 characters"),
        ({"t": True}, "t must be a number"),
        ({"t": None}, "t must be a number"),
        ({"t": {"v": 1}}, "t must be a number"),
        ({f"r{i}": 1 for i in range(65)}, "has more than 64 values"),
    ],
)
def test_readings_must_be_named_numbers(readings: Any, message: str) -> None:
    assert errors_of(record(readings=readings)) == {"readings": message}


# NUL is valid JSON but PostgreSQL's jsonb refuses it (the whole batch failed, a 500); a lone
# surrogate ("\\ud800" is a valid JSON escape) is not even UTF-8: jsonb refuses it and, stored
# on SQLite, it broke every page that renders the fix.
UNSTORABLE = ["a\x00b", "a\ud800b"]


@pytest.mark.parametrize("name", UNSTORABLE)
def test_a_reading_name_that_cannot_be_stored_is_refused(name: str) -> None:
    errors = errors_of(record(readings={name: 1.0}))
    assert list(errors) == ["readings"]
    assert "cannot be stored" in errors["readings"]
    json.dumps(errors, ensure_ascii=False).encode()  # the reply can carry it


@pytest.mark.parametrize("name", UNSTORABLE)
def test_a_field_name_that_cannot_be_stored_is_named_safely(name: str) -> None:
    unknown = errors_of(record(**{name: 1}))
    bad_value = errors_of(record(readings={"t": "x", name: 1.0}))
    legacy = pytest.raises(
        FixErrors, parse_legacy_fix, {"latitude": 1, "longitude": 1, name: 1.0}, now=NOW
    ).value.errors
    legacy_value = pytest.raises(
        FixErrors, parse_legacy_fix, {"latitude": 1, "longitude": 1, name: "x"}, now=NOW
    ).value.errors
    for errors in (unknown, bad_value, legacy, legacy_value):
        assert errors
        json.dumps(errors, ensure_ascii=False).encode()


# --- legacy records (docs/api.md#legacy-spab-endpoints) ---


def test_it_parses_a_listing_1_record() -> None:
    fix = parse_legacy_fix(
        {
            "timestamp": 1536551550,
            "latitude": -31.9505,
            "longitude": 115.8605,
            "temperature": 301.3,
            "salinity": 35.5,
        },
        now=NOW,
    )
    assert fix == FixData(
        recorded_at=dt.datetime(2018, 9, 10, 3, 52, 30, tzinfo=dt.UTC),
        lat=-31.9505,
        lon=115.8605,
        readings={"temperature": 301.3, "salinity": 35.5},
    )


def test_it_reads_10_microsecond_ticks_since_2015() -> None:
    when = dt.datetime(2026, 11, 23, 9, 0, 0, 10, tzinfo=dt.UTC)
    raw = int((when - LEGACY_EPOCH).total_seconds() * 100_000)
    assert legacy_time(raw, now=NOW, max_future_s=300) == when
    assert legacy_time(1536551550, now=NOW, max_future_s=300) == dt.datetime(
        2018, 9, 10, 3, 52, 30, tzinfo=dt.UTC
    )


@pytest.mark.parametrize(
    "raw",
    [123_456, 0, -1, 1e30, 4_102_444_800, "x", None, True, float("nan"), 10**400],
)
def test_an_implausible_legacy_time_is_none(raw: Any) -> None:
    assert legacy_time(raw, now=NOW, max_future_s=300) is None


def test_an_implausible_legacy_time_becomes_the_receive_time_plus_the_index() -> None:
    fixes = [
        parse_legacy_fix({"timestamp": 5000, "latitude": 0, "longitude": 0}, now=NOW, index=i)
        for i in range(3)
    ]
    assert [f.recorded_at for f in fixes] == [NOW + dt.timedelta(microseconds=i) for i in range(3)]
    assert all(f.readings == {"timestamp_raw": 5000.0} for f in fixes)


def test_a_legacy_record_names_its_bad_fields() -> None:
    with pytest.raises(FixErrors) as err:
        parse_legacy_fix(
            {"timestamp": 1536551550, "latitude": True, "temperature": "warm"}, now=NOW
        )
    assert err.value.errors == {
        "latitude": "must be a number",
        "longitude": "is required",
        "temperature": "must be a number",
    }


def test_a_legacy_record_must_be_an_object() -> None:
    with pytest.raises(FixErrors) as err:
        parse_legacy_fix([1, 2], now=NOW)
    assert err.value.errors == {"non_field_errors": "each record must be a JSON object"}


# --- property-based: only FixErrors, whatever a boat sends ---

json_values = st.recursive(
    st.none()
    | st.booleans()
    | st.integers()
    | st.integers(min_value=10**300, max_value=10**400)
    | st.floats()
    | st.text(max_size=30),
    lambda children: (
        st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=8), children, max_size=3)
    ),
    max_leaves=10,
)
FIELDS = ["time", "lat", "lon", "heading_deg", "speed_mps", "battery_v", "readings", "x"]
LEGACY_FIELDS = ["timestamp", "latitude", "longitude", "temperature", "salinity"]


def _records(fields: list[str]) -> st.SearchStrategy[Any]:
    return st.dictionaries(st.sampled_from(fields), json_values, max_size=len(fields)) | json_values


@given(_records(FIELDS))
@example({"time": 10**400, "lat": 10**400, "lon": 0})
@example({"time": "9999-12-31T23:59:59+14:00", "lat": 0, "lon": 0})
@example({"time": "0001-01-01T00:00:00-14:00", "lat": 0, "lon": 0})
def test_parse_fix_raises_only_fix_errors(raw: Any) -> None:
    try:
        fix = parse_fix(raw, now=NOW)
    except FixErrors as exc:
        assert exc.errors
        return
    assert -90 <= fix.lat <= 90 and -180 <= fix.lon <= 180
    assert fix.heading_deg is None or 0 <= fix.heading_deg < 360


@given(_records(LEGACY_FIELDS), st.integers(min_value=0, max_value=5000))
@example({"timestamp": 10**400, "latitude": 0, "longitude": 0}, 0)
def test_parse_legacy_fix_raises_only_fix_errors(raw: Any, index: int) -> None:
    try:
        fix = parse_legacy_fix(raw, now=NOW, index=index)
    except FixErrors as exc:
        assert exc.errors
        return
    assert fix.recorded_at <= NOW + dt.timedelta(seconds=300)


def test_a_legacy_timestamp_sent_as_a_string_is_still_read() -> None:
    now = dt.datetime(2026, 11, 23, 12, 0, tzinfo=dt.UTC)
    fix = parse_legacy_fix({"timestamp": "1536551550", "latitude": 1, "longitude": 2}, now=now)
    assert fix.recorded_at == dt.datetime(2018, 9, 10, 3, 52, 30, tzinfo=dt.UTC)
    odd = parse_legacy_fix({"timestamp": "12345", "latitude": 1, "longitude": 2}, now=now)
    assert odd.recorded_at == now and odd.readings == {"timestamp_raw": 12345.0}
