"""The compact command form (edge_client/contract/compact_command.py): every kind round-trips
within its stated resolution, nothing but a command decodes, and the limit holds."""

from __future__ import annotations

import math
import uuid
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from edge_client.contract import compact_command as cc
from edge_client.contract.catalog import HOLD_MAX_S, MISSION_ENDS
from edge_client.contract.kinds import ROVER_MODES

RESOLUTION = {"lat": 0.5e-7, "lon": 0.5e-7, "hold_s": 0.05, "radius_m": 0.05, "speed_mps": 0.005}

lats = st.floats(-90, 90, allow_nan=False)
lons = st.floats(-180, 180, allow_nan=False)
u8s = st.integers(0, 255)
items = st.fixed_dictionaries(
    {
        "lat": lats,
        "lon": lons,
        "hold_s": st.floats(0, HOLD_MAX_S) | st.none(),
        "radius_m": st.floats(0.5, 1000) | st.none(),
        "speed_mps": st.floats(0.1, 20) | st.none(),
    }
)
fence_sets = st.lists(
    st.fixed_dictionaries(
        {
            "id": st.integers(1, 10**6),
            "name": st.text(max_size=10),
            "inclusion": st.booleans(),
            "circle": st.fixed_dictionaries(
                {"lat": lats, "lon": lons, "radius_m": st.floats(1, 10_000)}
            ),
        }
    ),
    max_size=3,
)
PARAMS: dict[str, st.SearchStrategy[dict[str, Any]]] = {
    "move_to": st.fixed_dictionaries({"lat": lats, "lon": lons}),
    "hold": st.just({}),
    "resume": st.just({}),
    "return_home": st.just({}),
    "set_mode": st.fixed_dictionaries({"mode": st.sampled_from(sorted(ROVER_MODES))}),
    "arm": st.just({}),
    "disarm": st.just({}),
    "mission": st.fixed_dictionaries(
        {
            "mission_id": st.integers(1, 2**40) | st.none(),
            "items": st.lists(items, min_size=1, max_size=12),
            "loop": st.booleans(),
            "end": st.sampled_from(MISSION_ENDS) | st.none(),
        }
    ),
    "fence": st.fixed_dictionaries({"fences": fence_sets}),
    "fhead": st.fixed_dictionaries({"bearing": st.integers(0, 359)}),
    "light": st.fixed_dictionaries({"state": st.sampled_from(["on", "off"])}),
    "ir": st.fixed_dictionaries({"state": st.sampled_from(["on", "off"])}),
    "waypoint": st.fixed_dictionaries({"index": st.integers(1, 254), "lat": lats, "lon": lons}),
    "holdwp": st.fixed_dictionaries({"index": st.integers(1, 254)}),
    "fseq": st.fixed_dictionaries({"target": u8s, "begin": u8s, "end": u8s}),
    "rudder": st.fixed_dictionaries({"angle": st.integers(-30, 30)}),
    "fcourse": st.fixed_dictionaries(
        {
            "mode": st.sampled_from(["LOOP", "HOLD"]),
            "indices": st.lists(st.integers(1, 254), min_size=1, max_size=40),
        }
    ),
}
commands = st.sampled_from(sorted(PARAMS)).flatmap(
    lambda kind: st.tuples(st.uuids(), st.just(kind), PARAMS[kind])
)


def close(sent: Any, got: Any, name: str = "") -> bool:
    if isinstance(sent, dict):
        return sent.keys() == got.keys() and all(close(sent[k], got[k], k) for k in sent)
    if isinstance(sent, list):
        pairs = zip(sent, got, strict=False)
        return len(sent) == len(got) and all(close(a, b, name) for a, b in pairs)
    if isinstance(sent, float) and name in RESOLUTION:
        return math.isclose(sent, got, abs_tol=RESOLUTION[name] + 1e-12)
    return sent == got and type(sent) is type(got)


def test_every_kind_has_a_strategy() -> None:
    assert sorted(PARAMS) == sorted(name for name, _ in cc.KINDS)


@settings(max_examples=400)
@given(commands)
def test_decode_of_encode_keeps_every_field_within_its_resolution(command: Any) -> None:
    uid, kind, params = command
    try:
        data = cc.encode(uid, kind, params)
    except cc.CompactCommandError as exc:
        assert "at most 270" in str(exc)  # the only refusal of a valid command: its size
        return
    assert len(data) <= cc.MAX_BYTES
    back = cc.decode(data)
    assert back.uid == str(uid) and back.kind == kind
    assert close(params, back.params), (params, back.params)


@settings(max_examples=2000)
@given(st.binary(max_size=300))
def test_garbage_is_refused_never_a_crash(data: bytes) -> None:
    try:
        back = cc.decode(data)
    except cc.CompactCommandError:
        return
    # What decodes is a command this form writes: the same bytes again.
    assert cc.encode(back.uid, back.kind, back.params) == data


@given(commands, st.data())
def test_a_changed_byte_never_crashes_the_decoder(command: Any, data: st.DataObject) -> None:
    uid, kind, params = command
    try:
        wire = bytearray(cc.encode(uid, kind, params))
    except cc.CompactCommandError:
        return
    at = data.draw(st.integers(0, len(wire) - 1))
    wire[at] = data.draw(st.integers(0, 255))
    cut = data.draw(st.integers(0, len(wire)))
    try:
        cc.decode(bytes(wire[:cut]))
    except cc.CompactCommandError:
        pass


def test_a_move_to_is_27_bytes_one_sbd_credit() -> None:
    data = cc.encode(uuid.UUID(int=1), "move_to", {"lat": -32.05, "lon": 115.74})
    assert len(data) == 27 and data[0] == cc.VERSION
    assert cc.decode(data).params == {"lat": -32.05, "lon": 115.74}


def test_a_mission_past_270_bytes_is_refused_by_name() -> None:
    item = {"lat": -32.0, "lon": 115.0, "hold_s": 0.0, "radius_m": None, "speed_mps": None}
    fits = {"mission_id": 1, "items": [item] * 24, "loop": False, "end": "stop"}
    assert len(cc.encode(uuid.uuid4(), "mission", fits)) <= 270
    with pytest.raises(cc.CompactCommandError, match="at most 270"):
        cc.encode(uuid.uuid4(), "mission", {**fits, "items": [item] * 40})


@pytest.mark.parametrize(
    ("kind", "params", "message"),
    [
        ("launch", {}, "no kind"),
        ("hold", {"x": 1}, "takes no parameters"),
        ("move_to", {"lat": 1.0, "lon": 2.0, "alt": 3}, "no place for 'alt'"),
        ("set_mode", {"mode": "FLY"}, "not a Rover mode"),
        ("rudder", {"angle": 300}, "does not fit"),
        ("fence", {"fences": [float("nan")]}, "JSON cannot carry"),
    ],
)
def test_what_has_no_place_is_refused(kind: str, params: dict[str, Any], message: str) -> None:
    with pytest.raises(cc.CompactCommandError, match=message):
        cc.encode(uuid.uuid4(), kind, params)


def test_a_deflate_bomb_is_refused() -> None:
    import zlib

    packer = zlib.compressobj(9, zlib.DEFLATED, -15)
    bomb = packer.compress(b"[" + b"0," * 200_000 + b"0]") + packer.flush()
    assert len(bomb) < 1000  # inflates to 400 kB
    header = bytes([cc.VERSION]) + uuid.uuid4().bytes + bytes([8, 0x80])
    data = header + cc.TYPES["uvar"][0](len(bomb)) + bomb
    with pytest.raises(cc.CompactCommandError, match="too large|cut short"):
        cc.decode(data)
