"""Operator API for vessels (docs/api.md): the list and one vessel; only the move_to limit can be
changed (PATCH, tests/commands/test_move_limit.py)."""

from __future__ import annotations

from typing import Any

import pytest
from rest_framework.test import APIClient

from tests.support import VESSELS
from vessels.models import Vessel


def test_it_lists_vessels_with_their_last_fix_and_state(
    operator: APIClient, vessel_a: Vessel, vessel_b: Vessel, glider: Vessel, track: Any
) -> None:
    body = operator.get(VESSELS).json()
    assert [v["slug"] for v in body] == ["spab", "spab-2", "glider"]  # by name
    spab = next(v for v in body if v["slug"] == "spab")
    assert spab["kind"] == "mavlink"
    assert spab["last_fix"]["time"] == "2026-11-23T08:09:00+00:00"
    assert spab["last_fix"]["lat"] == pytest.approx(-31.91)
    assert spab["last_fix_at"] == "2026-11-23T08:09:00Z"
    assert spab["status"] in {"reporting", "overdue"}
    other = next(v for v in body if v["slug"] == "spab-2")
    assert (other["status"], other["last_fix"]) == ("never seen", None)


def test_it_shows_one_vessel_by_slug(operator: APIClient, glider: Vessel) -> None:
    body = operator.get(f"{VESSELS}glider/").json()
    assert (body["slug"], body["name"], body["kind"]) == ("glider", "Wave Glider", "wave_glider")
    response = operator.get(f"{VESSELS}nope/")
    assert response.status_code == 404
    assert response.json()["error"] == "not_found"


def test_the_vessel_api_is_read_only(operator: APIClient, vessel_a: Vessel) -> None:
    # Refused by permission (no add/delete right) or by method: either way nothing changes.
    assert operator.post(VESSELS, {"slug": "x", "name": "X"}, format="json").status_code in (
        403,
        405,
    )
    assert operator.delete(f"{VESSELS}spab/").status_code in (403, 405)
    assert Vessel.objects.count() == 1
    assert Vessel.objects.filter(slug="spab").exists()


# --- fixes ---
