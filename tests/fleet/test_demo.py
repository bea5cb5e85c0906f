"""The demo: `manage.py seed_demo` (a usable fleet with history) and `manage.py simulate_boat`
(the Rover simulator and the real edge client against a live server)."""

from __future__ import annotations

import io
import json
import os
import re
from pathlib import Path

import pytest
from django.contrib.auth.models import User
from django.core.management import CommandError, call_command

from commands.models import Command
from commands.services import command_enqueue
from edge_client.contract.geo import distance_m
from telemetry.models import Fix
from tests.conftest import give_position
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import start, stop, wait_until
from vessels.keys import hash_key
from vessels.models import Vessel, VesselKey

START = (-31.9790, 115.8170)
TARGET = (-31.9795, 115.8175)  # ~70 m south-east


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


@pytest.mark.slow
@pytest.mark.django_db(transaction=True)
def test_it_runs_a_boat_that_reports_and_carries_out_a_command_then_stops_cleanly(
    live_server, vessel_a: Vessel, key_a: str, tmp_path: Path
) -> None:
    target = {"lat": TARGET[0], "lon": TARGET[1]}
    give_position(vessel_a, *START)  # where it last reported (a move_to is measured from it)
    command = command_enqueue(vessel=vessel_a, kind="move_to", params=target)
    log = tmp_path / "boat.log"
    boat = start(
        ["manage.py", "simulate_boat", "--server", live_server.url, "--key", key_a,
         f"--start={START[0]},{START[1]}", "--port", str(free_port()), "--speed", "50",
         "--prearm-delay", "0.5", "--telemetry-period", "0.3", "--poll-period", "0.3",
         "--outbox", str(tmp_path / "outbox.sqlite3")],
        log,
    )  # fmt: skip
    try:
        wait_until(lambda: Command.objects.get(pk=command.pk).status == "done", 60, "move_to done")
        wait_until(lambda: Fix.objects.filter(vessel=vessel_a).count() >= 10, 30, "10 fixes")
        pids = [int(p) for p in re.findall(r"pid (\d+)", log.read_text())]
        assert len(pids) == 2 and all(alive(p) for p in pids), log.read_text()
    finally:
        status = stop(boat)
    output = log.read_text()
    assert status == 0 and "simulated boat stopped" in output, output
    assert not any(alive(p) for p in pids)  # both children stopped with it
    command.refresh_from_db()
    assert [e.to_status for e in command.events.all()] == ["queued", "sent", "acknowledged", "done"]
    assert "arrived within" in command.result_detail
    last = Fix.objects.filter(vessel=vessel_a).order_by("-recorded_at").first()
    assert last is not None and distance_m(last.lat, last.lon, *TARGET) < 15


def test_it_refuses_to_start_without_a_key(tmp_path: Path) -> None:
    with pytest.raises(CommandError, match="give --key or --key-file"):
        call_command("simulate_boat", "--outbox", str(tmp_path / "o.sqlite3"))


@pytest.mark.django_db
def test_seed_demo_makes_a_usable_fleet(tmp_path: Path) -> None:
    keys_file = tmp_path / "keys.json"
    out, _ = run_command("seed_demo", "--password", "demo-pw-1", "--keys-file", str(keys_file))
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
    # The demo phone may text the glider: sms_inject answers it, as the seed's output says.
    assert user.has_perm("sms.view_smsmessage") and "sms_inject --vessel glider" in out
    reply, _ = run_command("sms_inject", "--vessel", "glider", "--from", "+61400000001",
                           "--text", "#STATUS")  # fmt: skip
    assert reply.startswith("#STATUS")
    # Running it again keeps the fleet and its history and issues fresh keys.
    run_command("seed_demo", "--password", "demo-pw-2", "--keys-file", str(keys_file))
    assert Vessel.objects.count() == 3


def run_command(*args: str) -> tuple[str, str]:
    out, err = io.StringIO(), io.StringIO()
    call_command(*args, stdout=out, stderr=err)
    return out.getvalue(), err.getvalue()
