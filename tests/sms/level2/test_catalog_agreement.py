"""The inner command table and the command catalog name the same parameters.

The bridge hands a catalog-validated command (commands/catalog.py) to the Level 2 encoder; a
parameter the two spell differently would be refused on the glider, or worse, dropped. The table
holds only the wire layout and takes every range from the catalog.
Both modules are pure, so this needs no Django.
"""

from __future__ import annotations

import subprocess
import sys
import tomllib
from importlib import resources
from pathlib import Path

import pytest

from commands import catalog
from sms.level2.errors import CommandRefused, TableError
from sms.level2.inner import InnerCommandTable

TABLE = InnerCommandTable.load()
SHIPPED = tomllib.loads(
    resources.files("sms.level2").joinpath("inner_commands.toml").read_text("utf-8")
)
ROOT = Path(__file__).resolve().parents[3]
GLIDER_KINDS = [k for k in catalog.kinds_for(catalog.WAVE_GLIDER)]


@pytest.mark.parametrize("kind", GLIDER_KINDS, ids=lambda k: k.name)
def test_every_glider_command_of_the_catalog_has_a_table_entry_with_its_parameters(
    kind: catalog.CommandKind,
) -> None:
    spec = TABLE.commands[kind.name]
    assert [p.name for p in spec.params] == [p.name for p in kind.params]


@pytest.mark.parametrize(
    ("text", "expected_value"),
    [
        ("#FHEAD 230", 0x0008),
        ("#HOLD", 0x0002),
        ("#LIGHT ON", 0x2002),
        ("#WAYPOINT 1 -32.0380 115.3325", 0x8000),
    ],
)
def test_a_catalog_validated_command_encodes_for_the_sourced_entries(
    text: str, expected_value: int
) -> None:
    valid = catalog.parse_text(text)
    inner = TABLE.encode(valid.kind, valid.params)
    assert inner.packet.value == expected_value


@pytest.mark.parametrize("kind", GLIDER_KINDS, ids=lambda k: k.name)
def test_every_range_of_the_table_is_the_catalogs(kind: catalog.CommandKind) -> None:
    spec = TABLE.commands[kind.name]
    assert [(p.min, p.max) for p in spec.params] == [(p.minimum, p.maximum) for p in kind.params]


def test_the_shipped_table_gives_no_range_of_its_own() -> None:
    for entry in SHIPPED["commands"].values():
        for param in entry.get("params", []):
            assert not {"min", "max", "min_count"} & set(param), param


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("fhead 360", "bearing must be 0–359, got 360"),
        ("waypoint 255 0 0", "index must be 1–254, got 255"),
        ("waypoint 1 -90.5 0", "lat must be within ±90 degrees"),
    ],
)
def test_the_encoder_refuses_what_the_catalog_refuses(text: str, reason: str) -> None:
    with pytest.raises(catalog.CatalogError):
        catalog.parse_text("#" + text.upper())
    with pytest.raises(CommandRefused, match=reason):
        TABLE.parse(text)


def _with(word: str, **changes: object) -> dict:
    data = tomllib.loads(
        resources.files("sms.level2").joinpath("inner_commands.toml").read_text("utf-8")
    )
    data["commands"][word].update(changes)
    return data


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (
            _with("fhead", params=[{"name": "bearing", "type": "int", "min": 0, "max": 360}]),
            r"ranges come from the command catalog \(commands/catalog.py\)",
        ),
        (
            {"commands": {"jump": {"status": "sourced", "source": "s", "value": 1}}},
            r"\[commands.jump\]: not a command of the catalog",
        ),
        (
            _with(
                "fhead",
                params=[{"name": "heading", "type": "int"}],
                fields=[{"at": 3, "type": "u16", "from": "heading"}],
            ),
            r"parameters must be the catalog's: \['bearing'\]",
        ),  # fmt: skip
        (
            _with("fhead", params=[{"name": "bearing", "type": "lat"}], fields=[]),
            "bearing is 'int' in the catalog but 'lat' in the table",
        ),
        (
            _with(
                "light",
                params=[{"name": "state", "type": "choice", "choices": {"on": 1, "dim": 2}}],
            ),
            "state choices must be the catalog's: on/off",
        ),  # fmt: skip
    ],
)
def test_a_table_that_disagrees_with_the_catalog_is_refused_at_load(
    data: dict, message: str
) -> None:
    with pytest.raises(TableError, match=message):
        InnerCommandTable.from_dict(data)


def test_the_level2_library_and_the_catalog_load_without_django() -> None:
    code = (
        "import sys; import sms.level2, sms.level2.inner, commands.catalog;"
        "sms.level2.inner.InnerCommandTable.load();"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('django', 'rest_framework')))"
    )
    result = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"
