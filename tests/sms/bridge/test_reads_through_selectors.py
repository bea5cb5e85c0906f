"""The glider bridge reads its database through sms.selectors and writes it through services:
no manager, queryset or cursor of its own (issue 17 item 5)."""

from __future__ import annotations

import re
from pathlib import Path

import sms.bridge

BRIDGE = Path(sms.bridge.__file__).parent
DIRECT = re.compile(r"\.objects\b|\bcursor\(|\.raw\(|\bRawSQL\b")


def test_no_bridge_module_queries_the_database_itself() -> None:
    found = [
        f"{path.name}:{number}: {line.strip()}"
        for path in sorted(BRIDGE.glob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if DIRECT.search(line)
    ]
    assert found == []
