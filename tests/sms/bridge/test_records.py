"""The payload board's UDP records → readings (sms/bridge/records.py, sensor_layouts.toml)."""

from __future__ import annotations

import dataclasses
import struct
from typing import Any

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from sms.bridge.records import LayoutError, RecordError, RecordTable
from sms.level2.payload import SensorState

STASIS = RecordTable.load().records["stasis"]
READINGS = {
    "humidity_temp_c": 21.5,
    "humidity_pct": 35.0,
    "pressure_temp_c": -2.25,
    "pressure_kpa": 100.3,
    "leak1": 0.0,
    "leak2": 1.0,
}


def table(**record: Any) -> dict[str, Any]:
    base: dict[str, Any] = {
        "status": "provisional",
        "source": "a test",
        "port": 5000,
        "size": 4,
        "header": "AA",
        "fields": [{"reading": "temp_c", "at": 1, "type": "i16", "scale": 0.1}],
    }
    base.update(record)
    return {"records": {"r": base}}


def test_the_shipped_stasis_layout_is_provisional_and_feeds_the_status_block() -> None:
    assert STASIS.provisional and "no public source" in STASIS.source
    state_fields = {f.name for f in dataclasses.fields(SensorState)} - {"alarms"}
    assert {f.reading for f in STASIS.fields} == state_fields


def test_a_record_round_trips_to_its_readings() -> None:
    decoded = STASIS.decode(STASIS.encode(READINGS))
    assert decoded.readings == READINGS and decoded.dropped == {}


def test_the_documented_bytes_decode_as_documented() -> None:
    # header "ST" 1; 21.50 °C; 35.00 %; -2.25 °C; 100.30 kPa; leaks 0 and 1 (little-endian)
    record = bytes.fromhex("535401 6608 ac0d 1fff 2e27 00 01".replace(" ", ""))
    assert STASIS.decode(record).readings == READINGS


def test_a_longer_record_is_read_and_its_tail_ignored() -> None:
    assert STASIS.decode(STASIS.encode(READINGS) + b"\x99\x99").readings == READINGS


@pytest.mark.parametrize(
    ("data", "reason"),
    [(b"", "short"), (STASIS.encode(READINGS)[:-1], "short"), (b"XX" + bytes(11), "header")],
)
def test_short_or_foreign_datagrams_are_not_records(data: bytes, reason: str) -> None:
    with pytest.raises(RecordError) as caught:
        STASIS.decode(data)
    assert caught.value.reason == reason


def test_an_implausible_value_drops_that_reading_only() -> None:
    record = bytearray(STASIS.encode(READINGS))
    struct.pack_into("<H", record, 5, 15_000)  # 150 % humidity
    decoded = STASIS.decode(bytes(record))
    assert "humidity_pct" not in decoded.readings
    assert decoded.dropped == {"humidity_pct": "150 outside 0–100"}
    assert decoded.readings["pressure_kpa"] == 100.3


def test_a_nan_float_field_is_dropped() -> None:
    layout = RecordTable.from_dict(
        table(size=5, fields=[{"reading": "x", "at": 1, "type": "f32"}])
    ).records["r"]
    decoded = layout.decode(b"\xaa" + struct.pack("<f", float("nan")))
    assert decoded.readings == {} and decoded.dropped == {"x": "not a number"}


@given(st.binary(max_size=40))
@example(b"ST\x01")
@example(b"ST\x01" + b"\xff" * 10)
def test_any_bytes_decode_or_raise_the_record_error(data: bytes) -> None:
    try:
        decoded = STASIS.decode(data)
    except RecordError:
        return
    assert set(decoded.readings) | set(decoded.dropped) == {f.reading for f in STASIS.fields}


@pytest.mark.parametrize(
    ("change", "complaint"),
    [
        ({"status": "guess"}, "status"),
        ({"source": ""}, "source"),
        ({"port": 70000}, "port"),
        ({"size": 2}, "leaves the record"),
        ({"header": "AA BB"}, "overlaps"),
        ({"fields": [{"reading": "x", "at": 1, "type": "u64"}]}, "type"),
        ({"fields": [{"reading": "Bad Key", "at": 1, "type": "u8"}]}, "reading key"),
        ({"fields": [{"reading": "x", "at": 1, "type": "u8", "scale": 0}]}, "scale"),
        ({"fields": [{"reading": "x", "at": 1, "type": "u8", "min": 0}]}, "min and max"),
        ({"fields": []}, "at least one field"),
        ({"fields": [{"at": 1, "type": "u8"}]}, "malformed"),
        ({"byte_order": "middle"}, "byte_order"),
    ],
)
def test_a_bad_table_is_refused_with_a_reason(change: dict[str, Any], complaint: str) -> None:
    with pytest.raises(LayoutError, match=complaint):
        RecordTable.from_dict(table(**change))


def test_two_records_may_not_share_a_port_or_a_reading() -> None:
    one = table()["records"]["r"]
    with pytest.raises(LayoutError, match="share a port"):
        RecordTable.from_dict({"records": {"a": one, "b": one}})
    with pytest.raises(LayoutError, match="two fields"):
        RecordTable.from_dict({"records": {"a": one, "b": {**one, "port": 5001}}})


def test_a_table_that_is_not_toml_is_refused(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "layouts.toml"
    path.write_text("[records.r\n")
    with pytest.raises(LayoutError, match="not valid TOML"):
        RecordTable.load(path)
