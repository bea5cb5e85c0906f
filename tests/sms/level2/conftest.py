"""Fixtures for the Level 2 tests: the two real captures (tests/sms/level2/data/README.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

from sms.level2.cfa import Capture, read_cfa

DATA = Path(__file__).parent / "data"
CAPTURE_FILES = ("OA_enum_first_2014Mar19.cfa", "Responses.cfa")


@pytest.fixture(scope="session")
def captures() -> dict[str, Capture]:
    return {name: read_cfa((DATA / name).read_bytes()) for name in CAPTURE_FILES}
