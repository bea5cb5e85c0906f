"""The compact fix encoding (edge_client/contract/compact.py): what survives a round trip, how
small it is, and that nothing but a payload of ours ever decodes into fixes."""

from __future__ import annotations

import datetime as dt
import json
import math
import random
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edge_client.contract import compact
from edge_client.contract.bits import BitReader, BitsError, BitWriter, unzigzag, zigzag
from edge_client.contract.compact import Channel, CompactError, decode, encode

ROOT = Path(__file__).resolve().parents[2]
CHANNELS = [Channel("humidity_pct", 0.1), Channel("water_temp_c", 0.01), Channel("depth_m", 0.5)]
T0 = 1_790_000_000  # 2026-09-21
SBD_BYTES = 340

# Within half a step after rounding, and the last digit the decoder rounds to.
SLACK = 1e-6


def seconds(value: Any) -> float:
    if isinstance(value, str):
        return dt.datetime.fromisoformat(value).timestamp()
    return float(value)


def assert_kept(original: dict[str, Any], decoded: dict[str, Any], channels=CHANNELS) -> None:
    assert abs(seconds(decoded["time"]) - seconds(original["time"])) <= 0.5
    assert abs(decoded["lat"] - original["lat"]) <= 90 / compact.LAT_MAX + SLACK
    assert abs(decoded["lon"] - original["lon"]) <= 180 / compact.LON_MAX + SLACK
    if original.get("heading_deg") is None:
        assert "heading_deg" not in decoded
    else:
        off = abs(decoded["heading_deg"] - original["heading_deg"]) % 360
        assert min(off, 360 - off) <= 0.5 + SLACK
    for name, step in (("speed_mps", 0.1), ("battery_v", 0.01)):
        if original.get(name) is None:
            assert name not in decoded
        else:
            assert abs(decoded[name] - original[name]) <= step / 2 + SLACK
    steps = {c.name: c.step for c in channels}
    readings = original.get("readings") or {}
    assert set(decoded.get("readings", {})) == set(readings)
    for name, value in readings.items():
        assert abs(decoded["readings"][name] - value) <= steps[name] / 2 + SLACK


def reading_values(step: float) -> st.SearchStrategy[float]:
    return st.floats(-1e6, 1e6, allow_nan=False).map(lambda v: round(v / step) * step)


fix_strategy = st.fixed_dictionaries(
    {
        "time": st.integers(0, compact.MAX_TIME),
        "lat": st.floats(-90, 90),
        "lon": st.floats(-180, 180),
    },
    optional={
        "heading_deg": st.floats(0, 360),
        "speed_mps": st.floats(0, 1000),
        "battery_v": st.floats(0, 1000),
        "readings": st.dictionaries(
            st.sampled_from([c.name for c in CHANNELS]), st.floats(-1e6, 1e6), min_size=1
        ),
    },
)


@settings(max_examples=300, deadline=None)
@given(st.lists(fix_strategy, min_size=1, max_size=40))
def test_every_field_survives_within_its_step(fixes: list[dict[str, Any]]) -> None:
    decoded = decode(encode(fixes, CHANNELS), CHANNELS)
    assert len(decoded) == len(fixes)
    ordered = sorted(fixes, key=lambda f: round(f["time"]))  # the payload is in time order
    for original, out in zip(ordered, decoded, strict=True):
        assert_kept(original, out)


def track(n: int, *, period_s: int = 10, seed: int = 7, readings: bool = True) -> list[dict]:
    """A boat on a wandering course at 1.5-2.5 m/s, GPS noise of a metre or two, battery and
    two sensors drifting: what the SPAB reports."""
    rng = random.Random(seed)
    lat, lon, heading, speed, volts = -32.05, 115.74, 80.0, 2.0, 12.60
    humidity, water = 41.0, 18.40
    fixes = []
    for i in range(n):
        heading = (heading + rng.gauss(0, 4)) % 360
        speed = min(2.5, max(1.5, speed + rng.gauss(0, 0.1)))
        north, east = math.cos(math.radians(heading)), math.sin(math.radians(heading))
        lat += speed * period_s * north / 111_320 + rng.gauss(0, 1.5) / 111_320
        lon += speed * period_s * east / (111_320 * math.cos(math.radians(lat)))
        volts -= rng.choice((0, 0, 0, 0.01))
        humidity += rng.gauss(0, 0.2)
        water += rng.gauss(0, 0.02)
        fix = {
            "time": T0 + period_s * i,
            "lat": round(lat, 6),
            "lon": round(lon, 6),
            "heading_deg": round(heading, 1),
            "speed_mps": round(speed, 2),
            "battery_v": round(volts, 2),
        }
        if readings:
            fix["readings"] = {"humidity_pct": round(humidity, 1), "water_temp_c": round(water, 2)}
        fixes.append(fix)
    return fixes


def test_sixty_fixes_of_a_boat_fit_one_iridium_sbd_message() -> None:
    fixes = track(60)
    payload = encode(fixes, CHANNELS)
    assert len(payload) <= SBD_BYTES
    for original, out in zip(fixes, decode(payload, CHANNELS), strict=True):
        assert_kept(original, out)
    # Without readings, about five bytes a fix even with the GPS's noise.
    bare = encode(track(60, readings=False))
    assert (len(bare) - compact.HEADER.size - compact.CRC_BYTES) / 60 <= 5


def test_an_absolute_fix_is_at_most_twelve_bytes() -> None:
    fix = {"time": T0, "lat": -32.0380, "lon": 115.3325, "heading_deg": 359.0,
           "speed_mps": 22.0, "battery_v": 69.99}  # fmt: skip
    stream = len(encode([fix])) - compact.HEADER.size - compact.CRC_BYTES
    assert stream <= 12
    # And one far from the one before it is written absolute again, not as a huge change.
    far = [fix, {**fix, "time": T0 + 10, "lat": 51.5, "lon": -0.12}]
    assert len(encode(far)) - len(encode([fix])) <= 12


def test_fixes_come_out_in_time_order_and_absent_fields_stay_absent() -> None:
    fixes = [
        {"time": "2026-11-28T10:00:20+08:00", "lat": 1.0, "lon": 2.0},
        {"time": "2026-11-28T02:00:10Z", "lat": 1.0001, "lon": 2.0001, "battery_v": 12.5},
    ]
    out = decode(encode(fixes))
    assert [f["time"] for f in out] == ["2026-11-28T02:00:10Z", "2026-11-28T02:00:20Z"]
    assert out[0]["battery_v"] == 12.5 and set(out[1]) == {"time", "lat", "lon"}


@pytest.mark.parametrize(
    ("fixes", "said"),
    [
        ([], "no fixes"),
        ([{"time": T0, "lat": 91, "lon": 0}], "fix 0: lat must be a number from -90 to 90"),
        ([{"time": T0, "lat": 0}], "fix 0: lon is required"),
        ([{"time": "yesterday", "lat": 0, "lon": 0}], "fix 0: time must be ISO 8601"),
        ([{"time": "2026-11-28T02:00:10", "lat": 0, "lon": 0}], "with a UTC offset"),
        ([{"time": T0, "lat": 0, "lon": 0, "speed_mps": True}], "speed_mps must be a number"),
        ([{"time": T0, "lat": 0, "lon": 0, "battery_v": math.nan}], "battery_v must be a number"),
        ([{"time": T0, "lat": 0, "lon": 0, "readings": {"salinity": 35}}], "salinity"),
        ([{"time": -1, "lat": 0, "lon": 0}], "time out of range"),
        (["a fix"], "fix 0: not an object"),
        ([{"time": T0, "lat": 0, "lon": 0, "readings": {"depth_m": 1e308}}], "too large"),
        ([{"time": T0, "lat": 0, "lon": 0, "readings": {"depth_m": -4e10}}], "too large"),
    ],
)
def test_what_cannot_be_encoded_is_refused_with_the_reason(fixes: list, said: str) -> None:
    with pytest.raises(CompactError, match=said.replace("(", r"\(")):
        encode(fixes, CHANNELS)


def test_unknown_readings_can_be_left_out_on_request() -> None:
    fix = {"time": T0, "lat": 0, "lon": 0, "readings": {"salinity": 35, "depth_m": 2.5}}
    out = decode(encode([fix], CHANNELS, drop_unknown=True), CHANNELS)
    assert out[0]["readings"] == {"depth_m": 2.5}


def test_readings_written_with_another_channel_table_are_refused_not_misread() -> None:
    payload = encode(track(5), CHANNELS)
    with pytest.raises(CompactError, match="channel table"):
        decode(payload, [Channel("water_temp_c", 0.01), Channel("humidity_pct", 0.1)])
    with pytest.raises(CompactError, match="channel table"):
        decode(payload)
    # Fixes without readings do not depend on the table.
    assert decode(encode(track(5, readings=False)), CHANNELS)


@settings(max_examples=300, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False), st.sampled_from(CHANNELS))
def test_whatever_reading_encodes_also_decodes(value: float, channel: Channel) -> None:
    fix = {"time": T0, "lat": 0, "lon": 0, "readings": {channel.name: value}}
    try:
        payload = encode([fix], CHANNELS)
    except CompactError:
        return
    (out,) = decode(payload, CHANNELS)
    assert abs(out["readings"][channel.name] - value) <= channel.step / 2 + abs(value) * 1e-12


def test_a_table_is_the_same_whether_its_steps_were_written_1_or_1_0() -> None:
    # The shore's table comes from JSON, the boat's from TOML: 1 and 1.0 must agree.
    assert compact.table_id([Channel("armed", 1)]) == compact.table_id([Channel("armed", 1.0)])
    assert compact.table_id([Channel("armed", 1)]) != compact.table_id([Channel("armed", 2)])
    fixes = [{"time": T0, "lat": 0, "lon": 0, "readings": {"armed": 1}}]
    assert decode(encode(fixes, [Channel("armed", 1)]), [Channel("armed", 1.0)])


def test_a_later_version_is_named() -> None:
    payload = bytearray(encode(track(2), CHANNELS))
    payload[0] = 0xA2
    with pytest.raises(CompactError, match="version 2; this reads 1"):
        decode(bytes(payload))


@settings(max_examples=2000, deadline=None)
@given(st.binary(max_size=400))
def test_garbage_never_decodes_to_a_fix(data: bytes) -> None:
    with pytest.raises(CompactError):
        decode(data, CHANNELS)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_a_payload_damaged_anywhere_is_refused(data: st.DataObject) -> None:
    payload = encode(track(20, seed=data.draw(st.integers(0, 99))), CHANNELS)
    bit = data.draw(st.integers(0, len(payload) * 8 - 1))
    damaged = bytearray(payload)
    damaged[bit // 8] ^= 0x80 >> (bit % 8)
    with pytest.raises(CompactError):
        decode(bytes(damaged), CHANNELS)
    cut = data.draw(st.integers(0, len(payload) - 1))
    with pytest.raises(CompactError):
        decode(payload[:cut], CHANNELS)


@settings(max_examples=300, deadline=None)
@given(st.binary(min_size=1, max_size=200))
def test_a_stream_with_a_correct_checksum_but_foreign_bits_is_refused_or_well_formed(
    stream: bytes,
) -> None:
    """Past the checksum, the stream's own checks hold: any bits under a right header and
    checksum either decode into fixes within every range, or are refused."""
    body = compact.HEADER.pack(compact.MARK, compact.FLAG_READINGS, compact.table_id(CHANNELS),
                               T0) + stream  # fmt: skip
    payload = body + compact.crc16(body).to_bytes(2, "big")
    try:
        fixes = decode(payload, CHANNELS)
    except CompactError:
        return
    for fix in fixes:
        assert -90 <= fix["lat"] <= 90 and -180 <= fix["lon"] <= 180
        assert 0 <= fix.get("speed_mps", 0) <= 1000 and 0 <= fix.get("battery_v", 0) <= 1000
        assert 0 <= fix.get("heading_deg", 0) < 360
        assert set(fix.get("readings", {})) <= {c.name for c in CHANNELS}


@given(st.integers(-(2**38), 2**38), st.integers(0, 12))
def test_exp_golomb_codes_round_trip(value: int, k: int) -> None:
    assert unzigzag(zigzag(value)) == value
    w = BitWriter()
    w.signed(value, k)
    w.write(5, 3)
    r = BitReader(w.bytes())
    assert r.signed(k) == value and r.read(3) == 5


def test_a_bit_reader_stops_at_the_end() -> None:
    with pytest.raises(BitsError):
        BitReader(b"\x00" * 8).exp_golomb(0)  # 64 zeros: no code this format writes
    with pytest.raises(BitsError):
        BitReader(b"\xff").read(9)


def test_a_channel_table_comes_from_its_json_form() -> None:
    table = compact.channels_from([{"name": "humidity_pct", "step": 0.1}, {"name": "depth_m"}])
    assert table == [Channel("humidity_pct", 0.1), Channel("depth_m", 0.01)]
    for bad in ([{"step": 1}], [{"name": "a", "step": 0}], [{"name": "a"}, {"name": "a"}], [3]):
        with pytest.raises(CompactError):
            compact.channels_from(bad)


# --- the command line: python -m edge_client compact encode|decode --------------------------


def cli(*args: str, stdin: bytes | None = None) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(
        [sys.executable, "-m", "edge_client", "compact", *args],
        cwd=ROOT, input=stdin, capture_output=True, timeout=60,
    )  # fmt: skip


def test_the_command_line_encodes_and_decodes_files(tmp_path: Path) -> None:
    fixes = track(30)
    source = tmp_path / "fixes.json"
    source.write_text(json.dumps({"fixes": fixes}))
    table = tmp_path / "channels.json"
    table.write_text(json.dumps([{"name": c.name, "step": c.step} for c in CHANNELS]))
    encoded = cli("encode", str(source), "--channels", str(table))
    assert encoded.returncode == 0, encoded.stderr
    assert encoded.stdout == encode(fixes, CHANNELS)
    assert b"30 fixes" in encoded.stderr  # the size, for people
    batch = tmp_path / "batch.bin"
    batch.write_bytes(encoded.stdout)
    decoded = cli("decode", str(batch), "--channels", str(table))
    assert decoded.returncode == 0, decoded.stderr
    out = json.loads(decoded.stdout)
    assert out == decode(encoded.stdout, CHANNELS)
    # From standard input too, and a bad file is a message, not a traceback.
    assert cli("decode", "-", "--channels", str(table), stdin=encoded.stdout).stdout
    refused = cli("decode", str(source))
    assert refused.returncode == 1
    assert refused.stderr.decode().strip() == (
        f"compact decode: {source}: not a compact payload (its first byte)"
    )
