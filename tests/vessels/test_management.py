"""Provisioning and demo commands, including a simulated boat against a live server."""

from __future__ import annotations

import io
import json
from collections import deque
from pathlib import Path

import pytest
import requests
from django.contrib.auth.models import User
from django.core.management import CommandError, call_command

from commands.models import Command
from commands.services import command_enqueue
from telemetry.models import Fix
from vessels.keys import hash_key
from vessels.management.commands.simulate_boat import Command as SimulateBoat
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


@pytest.mark.django_db(transaction=True)
def test_a_simulated_boat_reports_and_carries_out_a_command(
    live_server, vessel_a: Vessel, key_a: str
) -> None:
    command = command_enqueue(
        vessel=vessel_a, kind="move_to", params={"lat": -31.9795, "lon": 115.8170}
    )
    out, err = run(
        "simulate_boat",
        "--server",
        live_server.url,
        "--key",
        key_a,
        "--start=-31.9790,115.8170",
        "--sample",
        "0.2",
        "--period",
        "0.5",
        "--poll",
        "0.3",
        "--speedup",
        "20",
        "--duration",
        "4",
    )
    assert "accepted" in out, err
    command.refresh_from_db()
    assert command.status == "done", (out, err)
    assert [e.to_status for e in command.events.all()] == ["queued", "sent", "acknowledged", "done"]
    fixes = Fix.objects.filter(vessel=vessel_a)
    assert fixes.count() >= 10
    last = fixes.order_by("-recorded_at").first()
    assert abs(last.lat - -31.9795) < 0.0002


@pytest.mark.django_db(transaction=True)
def test_a_simulated_boat_keeps_its_fixes_while_its_key_is_refused(
    live_server, vessel_a: Vessel, key_a: str, revoked_key_a: str
) -> None:
    err = io.StringIO()
    sim = SimulateBoat(stdout=io.StringIO(), stderr=err)
    sim.server = live_server.url
    sim.http = requests.Session()
    sim.http.headers["Authorization"] = f"Api-Key {revoked_key_a}"
    sim.backlog = deque([{"time": "2026-11-23T10:00:00Z", "lat": -31.9, "lon": 115.8}])

    sim.do_one_post()
    assert "telemetry refused: 401" in err.getvalue()
    assert len(sim.backlog) == 1  # kept for the next try, not thrown away

    sim.http.headers["Authorization"] = f"Api-Key {key_a}"
    sim.do_one_post()
    assert len(sim.backlog) == 0
    assert Fix.objects.filter(vessel=vessel_a).count() == 1


@pytest.mark.django_db
def test_an_overlong_label_is_a_clear_error_and_issues_nothing(vessel_a: Vessel) -> None:
    out = io.StringIO()
    with pytest.raises(CommandError, match="label"):
        call_command("issue_key", "spab", "--label", "x" * 101, stdout=out, stderr=io.StringIO())
    assert out.getvalue() == ""
    assert not VesselKey.objects.exists()
