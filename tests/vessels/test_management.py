"""Provisioning and demo commands (simulate_boat: tests/fleet/test_simulate_boat.py)."""

from __future__ import annotations

import io
import json
from pathlib import Path

import pytest
from django.contrib.auth.models import User
from django.core.management import CommandError, call_command

from commands.models import Command
from telemetry.models import Fix
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
def test_seed_demo_makes_a_usable_fleet(tmp_path: Path) -> None:
    keys_file = tmp_path / "keys.json"
    out, _ = run("seed_demo", "--password", "demo-pw-1", "--keys-file", str(keys_file))
    assert "user: operator" in out and "demo-pw-1" in out
    user = User.objects.get(username="operator")
    assert user.check_password("demo-pw-1") and user.is_staff
    assert user.has_perm("commands.add_command") and not user.is_superuser
    keys = json.loads(keys_file.read_text())
    assert set(keys) == {"spab", "spab-2", "glider"}
    assert oct(keys_file.stat().st_mode & 0o777) == "0o600"
    for slug, raw in keys.items():
        assert VesselKey.objects.get(key_hash=hash_key(raw)).vessel.slug == slug
        vessel = Vessel.objects.get(slug=slug)
        assert vessel.last_fix is not None and Fix.objects.filter(vessel=vessel).count() > 30
    assert Command.objects.filter(status="done").exists()
    # Running it again keeps the fleet and its history and issues fresh keys.
    run("seed_demo", "--password", "demo-pw-2", "--keys-file", str(keys_file))
    assert Vessel.objects.count() == 3


@pytest.mark.django_db
def test_an_overlong_label_is_a_clear_error_and_issues_nothing(vessel_a: Vessel) -> None:
    out = io.StringIO()
    with pytest.raises(CommandError, match="label"):
        call_command("issue_key", "spab", "--label", "x" * 101, stdout=out, stderr=io.StringIO())
    assert out.getvalue() == ""
    assert not VesselKey.objects.exists()
