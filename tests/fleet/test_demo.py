"""The demo: `manage.py seed_demo` (a usable fleet with history), `manage.py simulate_boat`
(the Rover simulator and the real edge client against a live server) and `scripts/demo.sh`
(all of it at once, with the live Wave Glider: its bridge over simulated C&C and modem)."""

from __future__ import annotations

import datetime as dt
import io
import json
import os
import re
import signal
import socket
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
import requests
from django.contrib.auth.models import User
from django.core.management import CommandError, call_command

from alerts.models import AlertRule
from commands.models import Command
from commands.services import command_enqueue
from edge_client.contract.geo import distance_m
from telemetry.models import Fix
from tests.conftest import give_position
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import ROOT, start, stop, wait_until
from tests.fleet.demo_script import Demo, demo_env, free_boat_ports, gone_within
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
    # The operator watches the fleet too: the map's alert badges, rules, fences.
    assert user.has_perm("alerts.view_alert") and user.has_perm("alerts.change_alert")
    assert user.has_perm("alerts.add_alertrule") and user.has_perm("vessels.add_fence")
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
    # The alerts loop the demo runs has rules to watch: once each, however often it is seeded.
    kinds = sorted(AlertRule.objects.values_list("kind", flat=True))
    assert kinds == ["battery", "overdue", "reading"]


def run_command(*args: str) -> tuple[str, str]:
    out, err = io.StringIO(), io.StringIO()
    call_command(*args, stdout=out, stderr=err)
    return out.getvalue(), err.getvalue()


# -- scripts/demo.sh, run for real -------------------------------------------------------------


@pytest.fixture
def demo() -> Iterator[Demo]:
    run = Demo()
    try:
        yield run
    finally:
        run.close()


def glider_fix(api: requests.Session, demo: Demo) -> dict | None:
    fleet = api.get(f"{demo.site}/api/v1/fleet/", timeout=30).json()["vessels"]
    return next(v for v in fleet if v["slug"] == "glider")["last_fix"]


@pytest.mark.slow
def test_the_demo_glider_is_live_takes_an_fhead_and_an_sms_and_ctrl_c_stops_it_all(
    demo: Demo,
) -> None:
    started = dt.datetime.now(dt.UTC)
    demo.ready()
    text = demo.text()
    steps = ["migrating…", "collecting static files…", "seeding the demo fleet…",
             "starting the site…", "starting boats…", "starting the glider bridge…"]  # fmt: skip
    assert [s for s in steps if f"demo: {s}" in text] == steps
    assert text.rstrip().endswith(f"password: {demo.password}")  # the login comes last
    assert 'demo_sms "+61400000001" "#FHEAD 230"' in text
    api = demo.api()

    # The glider reports from off Fremantle, and moves.
    def live_fix() -> dict | None:
        fix = glider_fix(api, demo)
        return fix if fix and dt.datetime.fromisoformat(fix["time"]) > started else None

    first = wait_until(live_fix, 90, "a live fix of the glider")
    assert distance_m(first["lat"], first["lon"], -32.08, 115.70) < 500
    moved = wait_until(
        lambda: (f := live_fix()) and distance_m(f["lat"], f["lon"], first["lat"], first["lon"]) > 5
        and f, 90, "the glider moving",
    )  # fmt: skip

    # An fhead from the operator API reaches the C&C, which turns the glider and says so.
    queued = api.post(
        f"{demo.site}/api/v1/vessels/glider/commands/",
        json={"kind": "fhead", "params": {"bearing": 45}, "source": "map"},
        timeout=30,
    )
    assert queued.status_code == 201, queued.text
    uid = queued.json()["uid"]

    def command() -> dict:
        listed = api.get(f"{demo.site}/api/v1/vessels/glider/commands/", timeout=30).json()
        return next(c for c in listed["results"] if c["uid"] == uid)

    wait_until(lambda: command()["status"] == "done", 90, "the fhead done")
    done = command()
    statuses = [e["to_status"] for e in done["events"]]  # "acknowledged" if a poll saw it
    assert statuses[:2] == ["queued", "sent"] and statuses[-1] == "done", statuses
    assert done["result_detail"] == "C&C: ACK (accepted)"
    glider_log = (demo.data / "sim-glider.log").read_text()
    assert "C&C glider: following heading 045°" in glider_log
    turned = wait_until(lambda: (f := live_fix()) and f["time"] > moved["time"] and f, 60, "a fix")
    north_east = wait_until(
        lambda: (f := live_fix()) and f["lat"] > turned["lat"] and f["lon"] > turned["lon"] and f,
        90, "the glider going north-east",
    )  # fmt: skip
    assert north_east

    # An SMS typed into the demo's modem: its reply and its command in the shore's SMS log.
    said = demo.manage("demo_sms", "+61400000001", "#LIGHT ON")
    assert "arrived at the glider's modem" in said

    def logged() -> list[tuple]:
        return demo.query(
            "SELECT s.direction, s.text, s.outcome, s.reply_to_id, c.kind, c.status"
            " FROM sms_smsmessage s LEFT JOIN sms_smsmessage_commands sc ON sc.smsmessage_id = s.id"
            " LEFT JOIN commands_command c ON c.id = sc.command_id"
            " WHERE s.text LIKE '#LIGHT ON%' ORDER BY s.id"
        )

    wait_until(lambda: len(logged()) == 2, 90, "the SMS and its reply on the shore")
    (incoming, reply) = logged()
    assert incoming[:3] == ("in", "#LIGHT ON", "accepted") and incoming[4] == "light"
    assert reply[:2] == ("out", "#LIGHT ON OK") and reply[3] is not None
    wait_until(lambda: logged()[0][5] == "done", 60, "the SMS's command done on the shore")
    page = demo.admin().get(f"{demo.site}/admin/sms/smsmessage/", timeout=30).text
    assert "#LIGHT ON" in page and "#LIGHT ON OK" in page

    # Ctrl-C in the terminal (SIGINT to the whole group) stops everything the demo started.
    assert len(demo.processes()) >= 12, demo.processes()
    assert demo.signal(signal.SIGINT, group=True) == 130
    assert gone_within(demo, 5) == []
    assert "demo: stopped" in demo.text()


@pytest.mark.slow
def test_stopping_the_demo_script_alone_stops_everything_it_started(demo: Demo) -> None:
    demo.ready()
    running = "\n".join(demo.processes())
    for part in ("gunicorn", "rebuild_track_overview", "run_alerts", "simulate_boat",
                 "edge_client.sim", "edge_client run", "simulate_glider",
                 "run_wg_bridge"):  # fmt: skip
        assert part in running, running
    assert demo.signal(signal.SIGTERM) == 143  # the script only, as `kill PID` does
    assert gone_within(demo, 5) == []
    assert "demo: stopped" in demo.text()


@pytest.mark.parametrize("busy", ["PORT", "BOAT_PORT", "BOAT_PORT+10"])
def test_a_busy_port_stops_the_demo_before_anything_with_a_clear_message(
    busy: str, tmp_path: Path
) -> None:
    port, boat = free_port(socket.SOCK_STREAM), free_boat_ports()
    taken = {"PORT": port, "BOAT_PORT": boat, "BOAT_PORT+10": boat + 10}[busy]
    kind = socket.SOCK_STREAM if busy == "PORT" else socket.SOCK_DGRAM
    with socket.socket(socket.AF_INET, kind) as holder:
        holder.bind(("127.0.0.1", taken))
        if kind == socket.SOCK_STREAM:
            holder.listen()  # a server already there, as a second demo would be
        result = subprocess.run(
            ["bash", "scripts/demo.sh"], cwd=ROOT, capture_output=True, text=True, timeout=60,
            env=demo_env(PORT=str(port), BOAT_PORT=str(boat),
                         SHORESIDE_DATA_DIR=str(tmp_path / "data")),
        )  # fmt: skip
    said = result.stdout + result.stderr
    assert result.returncode == 1, said
    proto = "TCP" if busy == "PORT" else "UDP"
    assert f"demo: {proto} port {taken} ({busy}) is in use" in said
    assert f"{busy.removesuffix('+10')}=…" in said  # how to choose another
    assert "password" not in said and "migrating" not in said  # nothing was started
    assert not (tmp_path / "data").exists()


def test_a_port_that_is_not_a_number_is_refused(tmp_path: Path) -> None:
    result = subprocess.run(
        ["bash", "scripts/demo.sh"], cwd=ROOT, capture_output=True, text=True, timeout=60,
        env=demo_env(PORT="80a", SHORESIDE_DATA_DIR=str(tmp_path / "data")),
    )  # fmt: skip
    assert result.returncode == 1
    assert "PORT='80a' is not a port number" in result.stderr


def test_simulate_glider_refuses_to_start_without_a_key_or_with_a_bad_start() -> None:
    with pytest.raises(CommandError, match="give --key or --key-file"):
        call_command("simulate_glider")
    with pytest.raises(CommandError, match="--start must be lat,lon"):
        call_command("simulate_glider", "--key", "k", "--start", "somewhere")


def test_demo_sms_says_when_no_demo_is_running(tmp_path: Path) -> None:
    with pytest.raises(CommandError, match=r"no modem simulator listening at .*demo\.sh` running"):
        call_command("demo_sms", "+61400000001", "#STATUS", "--control", str(tmp_path / "x.sock"))
