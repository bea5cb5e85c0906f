"""The inner command table (§11.1, §13–§14 of docs/level2.md; docs/sms.md, the field trial)."""

from __future__ import annotations

import struct
import tomllib
from importlib import resources
from typing import Any

import pytest

from commands import catalog
from sms.level2.bodies import QueuedReply
from sms.level2.codec import CC_COMMAND, Address, Frame, MessageType
from sms.level2.errors import CommandRefused, TableError
from sms.level2.inner import InnerCommandTable

from .test_codec import GOBY_FHEAD, h

DESIGN_WORDS = {"fhead", "light", "ir", "hold", "waypoint", "holdwp", "fseq", "rudder", "fcourse"}
SHIPPED = resources.files("sms.level2").joinpath("inner_commands.toml").read_text("utf-8")


def table_with(extra: str = "", settings: str = "") -> InnerCommandTable:
    """The shipped table with some TOML appended or settings replaced, as an operator would."""
    text = SHIPPED
    if settings:
        start = text.index("[settings]")
        end = text.index("[commands.fhead]")
        text = text[:start] + "[settings]\n" + settings + "\n\n" + text[end:]
    return InnerCommandTable.from_toml(text + "\n" + extra)


def enabled(word: str, value: str = "") -> InnerCommandTable:
    data = tomllib.loads(SHIPPED)
    data["commands"][word]["enabled"] = True
    if value:
        data["commands"][word]["value"] = int(value, 16)
    return InnerCommandTable.from_dict(data)


def test_the_shipped_table_has_every_design_word_with_a_source() -> None:
    table = InnerCommandTable.load()
    assert set(table.commands) == DESIGN_WORDS
    assert all(spec.source for spec in table.commands.values())
    sourced = {w for w, spec in table.commands.items() if spec.status == "sourced"}
    assert sourced == {"fhead", "hold", "light", "waypoint"}
    assert table.settings.inner_size_includes_crc is False and table.settings.wgms_id == 0


def queued_frame(table: InnerCommandTable, text: str, tid: int = 0x1B) -> bytes:
    data = b"\x01\x00" + bytes(table.parse(text).packet)
    body = bytes(QueuedReply(data))
    return bytes(
        Frame.make(MessageType.ACK, body, tid=tid, dest=CC_COMMAND, src=Address(0x00, 0x01))
    )


def test_fhead_230_matches_the_pc_style_example() -> None:
    expected = bytearray(h(GOBY_FHEAD))
    expected[16:22] = h("00 00 00 00 10 00")  # §11.1: id 0, size 16
    expected[38:40] = h("1B 99")
    assert queued_frame(InnerCommandTable.load(), "fhead 230") == bytes(expected)


def test_fhead_230_matches_the_goby_example_with_goby_settings() -> None:
    goby = table_with(settings="inner_size_includes_crc = true\nwgms_id = 0xFFFFFFFF")
    assert queued_frame(goby, "#FHEAD 230") == h(GOBY_FHEAD)


@pytest.mark.parametrize(
    ("text", "value", "params"),
    [
        ("hold", 0x0002, "01 00 00 00 00"),
        ("light on", 0x2002, "00 00 00 00 00"),
        ("LIGHT OFF", 0x2001, "00 00 00 00 00"),
        ("fhead 0", 0x0008, "00 00 00 00 00"),
        ("fhead 359", 0x0008, "00 00 00 67 01"),
    ],
)
def test_sourced_commands_encode_their_public_values(text: str, value: int, params: str) -> None:
    packet = InnerCommandTable.load().parse(text).packet
    assert packet.value == value and packet.params == h(params)
    assert bytes(packet)[:7] == h("0A 00 00 00 00 10 00")


def test_waypoint_carries_index_and_coordinates() -> None:
    command = InnerCommandTable.load().parse("#WAYPOINT 1 -32.0380 115.3325")
    packet = command.packet
    assert packet.value == 0x8000 and packet.params == h("00 00 00 00 01")
    assert packet.lat == round(-32.0380 * 600_000) and packet.lon == round(115.3325 * 600_000)
    assert command.text == "waypoint 1 -32.038 115.3325"


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("fhead 360", "bearing must be 0–359"),
        ("fhead -1", "bearing must be 0–359"),
        ("fhead", "missing parameter 'bearing'"),
        ("fhead 1 2", "too many parameters"),
        ("fhead 12.5", "not a valid int"),
        ("light dim", "state must be one of on/off"),
        ("waypoint 255 0 0", "index must be 1–254"),
        ("waypoint 1 91 0", "lat must be within ±90"),
        ("waypoint 1 0 181", "lon must be within ±180"),
        ("jump 3", "not in the inner command table"),
        ("", "empty command"),
    ],
)
def test_bad_commands_are_refused_with_a_reason(text: str, reason: str) -> None:
    with pytest.raises(CommandRefused, match=reason):
        InnerCommandTable.load().parse(text)


@pytest.mark.parametrize("text", ["rudder 10", "ir on", "holdwp 1", "fseq 1 1 4", "fcourse hold 3"])
def test_provisional_entries_are_refused_unless_enabled(text: str) -> None:
    with pytest.raises(CommandRefused, match="provisional entry not enabled"):
        InnerCommandTable.load().parse(text)


def test_holdwp_when_enabled_sends_its_index_and_is_not_hold() -> None:
    # the 2018 field trial (docs/sms.md): "#HOLDWP 1" behaved like "#HOLD"
    table = enabled("holdwp")
    holdwp = table.parse("holdwp 1").packet
    assert holdwp.params[4] == 1
    assert bytes(holdwp) != bytes(table.parse("hold").packet)
    assert table.parse("holdwp 7").packet.params[4] == 7


def test_fseq_when_enabled_sends_all_three_indices() -> None:
    # the 2018 field trial (docs/sms.md): "#FSEQ 1 1 4" lost its last parameter
    command = enabled("fseq", value="0x9999").parse("fseq 1 1 4")
    assert command.packet.params[2:] == bytes((1, 1, 4))
    assert command.text == "fseq 1 1 4"
    with pytest.raises(CommandRefused, match="missing parameter 'end'"):
        enabled("fseq", value="0x9999").parse("fseq 1 1")


def test_a_table_entry_that_drops_a_parameter_is_refused_at_load() -> None:
    data = tomllib.loads(SHIPPED)
    data["commands"]["fseq"]["fields"].pop()  # forget where "end" goes
    with pytest.raises(TableError, match=r"\['end'\] are declared but never encoded"):
        InnerCommandTable.from_dict(data)


def test_an_entry_without_a_known_value_cannot_be_enabled() -> None:
    for word in ("fseq", "ir", "fcourse"):
        with pytest.raises(TableError, match="value is unknown"):
            enabled(word)


def test_rudder_when_enabled_chooses_the_command_by_sign() -> None:
    table = enabled("rudder")
    right, left, centre = (table.parse(f"rudder {a}").packet for a in (20, -20, 0))
    assert (right.value, left.value, centre.value) == (0x0004, 0x0005, 0x0006)
    assert struct.unpack_from("<H", right.params, 3)[0] == 20 == left.params[3]
    assert table.parse("rudder 10").provisional


def test_fcourse_when_enabled_takes_a_mode_and_indices() -> None:
    command = enabled("fcourse", value="0x9998").parse("#FCOURSE HOLD 3 4 1")
    assert command.packet.params == bytes((0, 3, 4, 1, 0))
    with pytest.raises(CommandRefused, match="takes 1–4 values"):
        enabled("fcourse", value="0x9998").parse("fcourse loop 1 2 3 4 5")


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('[commands.x]\nstatus = "maybe"\nsource = "s"', "status must be"),
        ('[commands.x]\nstatus = "sourced"', "needs a source"),
        (
            '[commands.x]\nstatus = "sourced"\nsource = "s"\nvalue = 1\n'
            'params = [{ name = "a", type = "int" }]\n'
            'fields = [{ at = 4, type = "u16", from = "a" }]',
            "leaves the 5 parameter bytes",
        ),
        (
            '[commands.x]\nstatus = "sourced"\nsource = "s"\nvalue = 1\n'
            'params = [{ name = "a", type = "float" }]',
            "unknown parameter type",
        ),
    ],
)
def test_table_mistakes_are_named(extra: str, message: str) -> None:
    with pytest.raises(TableError, match=message):
        table_with(extra)


def test_parameters_can_be_given_by_name() -> None:
    table = InnerCommandTable.load()
    assert table.encode("fhead", {"bearing": 230}).packet == table.parse("fhead 230").packet
    with pytest.raises(CommandRefused, match="unexpected parameters"):
        table.encode("fhead", {"bearing": 1, "speed": 2})


# --- check_valid: the SMS parser's shortcut must refuse exactly what encode refuses ---------


def _catalog_values(table: InnerCommandTable, word: str) -> list[dict[str, Any]]:
    """Every value the catalog accepts for each int and choice parameter (the ranges are
    small), each coordinate at its limits, one parameter varied at a time."""
    kind = catalog.get_kind(word)
    base: dict[str, Any] = {}
    options: dict[str, list[Any]] = {}
    for p in kind.params:
        if p.kind == "int":
            options[p.name] = list(range(int(p.minimum), int(p.maximum) + 1))
        elif p.kind == "choice":
            options[p.name] = list(p.choices)
        elif p.kind == "float":
            options[p.name] = [p.minimum, 0.0, p.maximum]
        else:  # indices: one to six of them
            options[p.name] = [[1] * n for n in range(1, 7)]
        base[p.name] = options[p.name][0]
    return [{**base, name: v} for name, values in options.items() for v in values]


def _refusal(call: Any, word: str, params: dict[str, Any]) -> str | None:
    try:
        call(word, params)
    except CommandRefused as exc:
        return exc.reason
    return None


def test_check_valid_refuses_what_encode_refuses_for_every_catalog_valid_value() -> None:
    data = tomllib.loads(
        resources.files("sms.level2").joinpath("inner_commands.toml").read_text("utf-8")
    )
    for entry in data["commands"].values():
        entry["enabled"] = True
        for p in entry.get("params", []):
            if p["type"] == "choice":
                p["choices"] = {k: 0x2000 + i for i, k in enumerate(p["choices"])}
        if not any(k in entry for k in ("value", "value_from", "value_by_sign")):
            entry["value"] = 0x0100
    # A field too narrow for the catalog's range: the shortcut must not be taken.
    data["commands"]["fhead"]["fields"] = [{"at": 3, "type": "u8", "from": "bearing"}]
    table = InnerCommandTable.from_dict(data)
    assert "fhead" not in table._encodes_all_valid  # noqa: SLF001 - the shortcut itself
    refused = 0
    for word in table.commands:
        for params in _catalog_values(table, word):
            valid = catalog.validate(word, params, vessel_kind=catalog.WAVE_GLIDER)
            expected = _refusal(table.encode, word, valid.params)
            assert _refusal(table.check_valid, word, valid.params) == expected
            refused += expected is not None
    assert refused > 0  # the narrow field and the long course lists were refused


def test_the_shipped_usable_entries_skip_the_encoding_for_catalog_valid_values() -> None:
    table = InnerCommandTable.load()
    usable = {w for w, s in table.commands.items() if s.usable}
    assert set(table._encodes_all_valid) == usable  # noqa: SLF001 - the shortcut itself
