"""The inner command table and the command catalog name the same parameters.

The bridge hands a catalog-validated command (commands/catalog.py) to the Level 2 encoder; a
parameter the two spell differently would be refused on the glider, or worse, dropped.
Both modules are pure, so this needs no Django.
"""

from __future__ import annotations

import pytest

from commands import catalog
from sms.level2.inner import InnerCommandTable

TABLE = InnerCommandTable.load()
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
