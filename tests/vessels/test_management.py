"""Provisioning and demo commands (simulate_boat: tests/fleet/test_simulate_boat.py)."""

from __future__ import annotations

import io

import pytest
from django.core.management import CommandError, call_command

from vessels.keys import hash_key
from vessels.models import Vessel, VesselKey


def run(*args: str, **opts: object) -> tuple[str, str]:
    out, err = io.StringIO(), io.StringIO()
    call_command(*args, stdout=out, stderr=err, **opts)
    return out.getvalue(), err.getvalue()


@pytest.mark.django_db
def test_create_vessel_and_issue_key_print_the_key_alone_on_stdout() -> None:
    run("create_vessel", "boat-9", "--name", "Boat nine", "--kind", "wave_glider")
    out, err = run("issue_key", "boat-9")
    raw = out.strip()
    assert "\n" not in raw and raw.startswith("ssk_")
    key = VesselKey.objects.get(vessel__slug="boat-9")
    assert key.key_hash == hash_key(raw)
    assert raw not in err and key.prefix in err
    assert Vessel.objects.get(slug="boat-9").kind == "wave_glider"


@pytest.mark.django_db
def test_provisioning_refuses_bad_input_clearly(vessel_a: Vessel) -> None:
    with pytest.raises(CommandError, match="slug"):
        run("create_vessel", "spab", "--name", "duplicate")
    with pytest.raises(CommandError, match="no vessel"):
        run("issue_key", "nope")
    with pytest.raises(CommandError, match="prefix, or pass --all"):
        run("revoke_key", "spab")


@pytest.mark.django_db
def test_revoke_key_revokes_by_prefix(key_a: str, vessel_a: Vessel) -> None:
    out, _ = run("revoke_key", "spab", key_a[:12])
    assert "revoked" in out
    assert VesselKey.objects.get(key_hash=hash_key(key_a)).revoked_at is not None


@pytest.mark.django_db
def test_an_overlong_label_is_a_clear_error_and_issues_nothing(vessel_a: Vessel) -> None:
    out = io.StringIO()
    with pytest.raises(CommandError, match="label"):
        call_command("issue_key", "spab", "--label", "x" * 101, stdout=out, stderr=io.StringIO())
    assert out.getvalue() == ""
    assert not VesselKey.objects.exists()
