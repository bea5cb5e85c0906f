"""End to end, all real processes: the live Django server, the simulator, the edge client.

The simulator runs fast (50 m/s, 10 Hz; the mission tests on a clock 4x real time) and the
client samples and polls every 0.3 s so the whole file stays well under a minute.
"""

from __future__ import annotations

import json
import sqlite3
import time
from dataclasses import replace
from itertools import pairwise
from pathlib import Path
from urllib.parse import urlsplit

import pytest

from commands.models import Command
from commands.services import command_enqueue
from edge_client.config import MavlinkConfig, OutboxConfig
from edge_client.contract.geo import distance_m
from edge_client.mavlink_link import MavlinkLink
from edge_client.mission import build_mission
from telemetry.models import Fix
from tests.conftest import give_position
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import (
    ModemStandIn,
    TcpProxy,
    outbox_counts,
    start,
    stop,
    wait_until,
)
from vessels.services import vessel_create, vessel_key_issue

pytestmark = [pytest.mark.django_db(transaction=True), pytest.mark.slow]

HOME = (-31.9800, 115.8200)
PERIOD = "0.3"
# The tests that wait on the boat booting, driving and holding run their simulator's clock
# this many times as fast (the client keeps real time). Holds are long enough on it that the
# client, sampling every PERIOD of real time, still takes two or more fixes at each waypoint.
FAST = "4"
HOLD_S = 2.5  # Rover keeps 3 whole seconds: 0.75 s of real time at 4x


@pytest.fixture
def boat(live_server):
    vessel = vessel_create(slug="spab", name="SPAB", kind="mavlink")
    _, key = vessel_key_issue(vessel=vessel, label="edge test")
    return vessel, key


class Rig:
    """Starts the simulator and the edge client as processes; stops them at the end."""

    def __init__(self, tmp_path: Path) -> None:
        self.tmp = tmp_path
        self.procs: list = []
        self.sim_port = free_port()
        self.observer_port = free_port()
        self.outbox = tmp_path / "outbox.sqlite3"

    def sim(self, *extra: str) -> None:
        self.procs.append(start(
            ["-m", "edge_client.sim", "--listen", f"udpin:127.0.0.1:{self.sim_port}",
             "--listen", f"udpin:127.0.0.1:{self.observer_port}", "--lat", str(HOME[0]),
             "--lon", str(HOME[1]), "--speed", "50", "--rate", "10", "--prearm-delay", "1",
             "--position-delay", "1",
             *extra],
            self.tmp / "sim.log",
        ))  # fmt: skip

    def client(self, server: str, key: str, *extra: str) -> None:
        self.edge = start(
            ["-m", "edge_client", "run", "--server", server, "--key", key,
             "--mavlink", f"udpout:127.0.0.1:{self.sim_port}", "--outbox", str(self.outbox),
             "--telemetry-period", PERIOD, "--poll-period", PERIOD, *extra],
            self.tmp / "edge.log",
        )  # fmt: skip
        self.procs.append(self.edge)

    def observer(self) -> MavlinkLink:
        """A second MAVLink peer on the simulator (like a GCS on another telemetry port)."""
        link = MavlinkLink(MavlinkConfig(connection=f"udpout:127.0.0.1:{self.observer_port}",
                                         source_component=190))  # fmt: skip
        link.start()
        assert link.wait_heartbeat(10)
        self.link = link
        return link

    def log(self) -> str:
        return (self.tmp / "edge.log").read_text()

    def close(self) -> None:
        if getattr(self, "link", None):
            self.link.stop()
        for proc in reversed(self.procs):
            stop(proc)


@pytest.fixture
def rig(tmp_path):
    r = Rig(tmp_path)
    yield r
    r.close()


def command_status(command: Command) -> str:
    command.refresh_from_db()
    return command.status


def test_move_to_end_to_end(live_server, boat, rig):
    vessel, key = boat
    rig.sim("--time-scale", FAST)
    rig.client(live_server.url, key)
    wait_until(lambda: Fix.objects.filter(vessel=vessel).exists(), 20, "a first fix")
    vessel.refresh_from_db()  # its last fix: a move_to is measured from it (MOVE_TO_MAX_M)
    target = (-31.9790, 115.8210)  # ~145 m north-east
    params = {"lat": target[0], "lon": target[1]}
    command = command_enqueue(vessel=vessel, kind="move_to", params=params, created_by="test")
    wait_until(lambda: command_status(command) in ("done", "failed"), 30, "move_to to finish")
    assert command.status == "done", (command.result_detail, rig.log()[-3000:])
    assert "arrived within" in command.result_detail
    wait_until(
        lambda: any(distance_m(f.lat, f.lon, *target) < 10
                    for f in Fix.objects.filter(vessel=vessel)),
        10, "a fix at the target",
    )  # fmt: skip
    assert stop(rig.edge) == 0


def test_a_command_waiting_when_the_boat_boots_is_carried_out(live_server, boat, rig):
    """The field report: queued before the boat starts, the autopilot not ready to take GUIDED
    for its first seconds; the client waits for the position instead of failing the command."""
    vessel, key = boat
    give_position(vessel, *HOME)  # where it last reported, before this boot (MOVE_TO_MAX_M)
    target = (-31.9795, 115.8205)
    command = command_enqueue(
        vessel=vessel,
        kind="move_to",
        params={"lat": target[0], "lon": target[1]},
        created_by="test",
    )
    # The Pi boots quicker than the autopilot: the client has the command before the autopilot
    # is even heard, and the autopilot takes 16 s of its clock (4 s of ours; the last flag wins
    # over the rig's 1 s) to get a position, some 2.5 s after it is first heard.
    rig.client(live_server.url, key)
    wait_until(lambda: command_status(command) != "queued", 20, "the boat to take the command")
    rig.sim("--position-delay", "16", "--time-scale", FAST)
    wait_until(lambda: command_status(command) in ("done", "failed"), 40, "move_to to finish")
    assert command.status == "done", (command.result_detail, rig.log()[-3000:])
    assert "waiting for a position estimate" in rig.log()  # it was refused and waited


FIVE = [
    {"lat": -31.9795, "lon": 115.8205, "hold_s": HOLD_S, "radius_m": 2},
    {"lat": -31.9790, "lon": 115.8212, "hold_s": HOLD_S, "radius_m": 2},
    {"lat": -31.9798, "lon": 115.8218, "hold_s": HOLD_S, "radius_m": 3},
    {"lat": -31.9806, "lon": 115.8211, "hold_s": HOLD_S, "radius_m": 2},
    {"lat": -31.9803, "lon": 115.8203, "hold_s": HOLD_S, "radius_m": 2},
]


def test_five_waypoint_mission_is_uploaded_read_back_and_followed(live_server, boat, rig):
    vessel, key = boat
    # default: the simulator asks for items with MISSION_REQUEST, as Rover does
    rig.sim("--time-scale", FAST)
    rig.client(live_server.url, key)
    observer = rig.observer()
    wait_until(lambda: Fix.objects.filter(vessel=vessel).exists(), 20, "a first fix")
    command = command_enqueue(vessel=vessel, kind="mission",
                              params={"mission_id": None, "items": FIVE, "loop": False},
                              created_by="test")  # fmt: skip
    wait_until(lambda: command_status(command) in ("acknowledged", "done", "failed"), 20)
    assert command.status != "failed", command.result_detail
    # Read it back from the autopilot over MAVLink: identical, home as item 0, except the
    # acceptance radius, which ArduPilot keeps for Plane only (sim/rover.py ``stored``).
    download = observer.download_mission()
    assert download.ok, download.error
    expected = [replace(i, param2=0.0) for i in build_mission(HOME, FIVE)]
    assert len(download.items) == 6
    assert all(a.same_route(b) for a, b in zip(download.items, expected, strict=True))
    wait_until(lambda: command_status(command) in ("done", "failed"), 40, "the mission to end")
    assert command.status == "done", command.result_detail
    # The track on the server passes each waypoint (the boat holds at each one).
    for wp in FIVE:
        wait_until(
            lambda wp=wp: any(distance_m(f.lat, f.lon, wp["lat"], wp["lon"]) <= wp["radius_m"] + 1
                              for f in Fix.objects.filter(vessel=vessel)),
            5, f"a fix at {wp}",
        )  # fmt: skip


def test_a_mission_ending_home_is_done_with_the_boat_back_home(live_server, boat, rig):
    vessel, key = boat
    rig.sim("--time-scale", FAST)
    rig.client(live_server.url, key)
    wait_until(lambda: Fix.objects.filter(vessel=vessel).exists(), 20, "a first fix")
    far = {"lat": -31.9790, "lon": 115.8212, "hold_s": HOLD_S, "radius_m": None, "speed_mps": 20}
    items = [FIVE[0], far]
    command = command_enqueue(vessel=vessel, kind="mission",
                              params={"items": items, "end": "return_home"},
                              created_by="test")  # fmt: skip
    wait_until(lambda: command_status(command) in ("done", "failed"), 40, "the mission to end")
    assert command.status == "done", (command.result_detail, rig.log()[-3000:])
    # The track shows the boat out at the far waypoint, and back home after it.
    wait_until(
        lambda: any(distance_m(f.lat, f.lon, far["lat"], far["lon"]) <= 3
                    for f in Fix.objects.filter(vessel=vessel)),
        5, "a fix at the far waypoint",
    )  # fmt: skip
    out_at = min(f.recorded_at for f in Fix.objects.filter(vessel=vessel)
                 if distance_m(f.lat, f.lon, far["lat"], far["lon"]) <= 3)  # fmt: skip
    wait_until(
        lambda: any(distance_m(f.lat, f.lon, *HOME) <= 10
                    for f in Fix.objects.filter(vessel=vessel, recorded_at__gt=out_at)),
        5, "a fix at home after the far waypoint",
    )  # fmt: skip
    # ... and the command was done only after that (one clock: boat and server share a host).
    assert "home" in command.result_detail and command.finished_at > out_at


def queued_fix_times(path: Path) -> list[float]:
    """The times of the fixes still in an (idle) outbox, Unix seconds."""
    db = sqlite3.connect(f"file:{path}?mode=ro", uri=True)
    try:
        rows = db.execute("SELECT body FROM outbox WHERE kind = 'fix'").fetchall()
    finally:
        db.close()
    return [float(json.loads(body)["time"]) for (body,) in rows]  # the edge client's Unix time


def test_after_an_outage_every_fix_is_on_the_server_exactly_once(live_server, boat, rig):
    vessel, key = boat
    proxy = TcpProxy(("127.0.0.1", urlsplit(live_server.url).port))
    rig.sim()
    rig.client(f"http://127.0.0.1:{proxy.port}", key)
    wait_until(lambda: Fix.objects.filter(vessel=vessel).count() >= 3, 20, "fixes flowing")
    down_at = time.time()
    proxy.down()
    # Once fixes pile up in the outbox, no request is getting through any more (one the
    # server was already handling may land before that: count from here).
    wait_until(lambda: outbox_counts(rig.outbox)["queued_fix"] >= 2, 20, "sends to fail")
    before = Fix.objects.filter(vessel=vessel).count()
    wait_until(lambda: outbox_counts(rig.outbox)["queued_fix"] >= 14, 30, "an outage backlog")
    assert Fix.objects.filter(vessel=vessel).count() == before
    up_at = time.time()
    proxy.up()
    wait_until(lambda: outbox_counts(rig.outbox)["queued_fix"] == 0, 30, "the backlog to drain")
    drained_at = time.monotonic()
    assert stop(rig.edge) == 0
    stopped_at = time.monotonic()
    proxy.down()
    counts = outbox_counts(rig.outbox)
    times = sorted(t.timestamp() for t in Fix.objects.filter(vessel=vessel)
                   .values_list("recorded_at", flat=True))  # fmt: skip
    # Nothing twice, nothing lost: every recorded fix is on the server, except the ones sampled
    # between the drain and SIGTERM (a fix waits for the next round; how many came depends on
    # how long the stop took on a loaded machine), which are still safe in the outbox.
    assert len(times) == len(set(times))
    assert counts.get("evicted_fixes", 0) == 0
    assert len(times) + counts["queued_fix"] == counts["recorded_fixes"]
    left = queued_fix_times(rig.outbox)
    # Left: the fixes sampled between the drain and the stop, and those sampled before the
    # drain but not yet committed when this test saw the outbox empty (group commits: fewer
    # than commit_every, from its own connection it cannot see them). Their times cannot tell
    # the two apart on a loaded machine, so count them.
    most = (stopped_at - drained_at) / float(PERIOD) + OutboxConfig().commit_every + 1
    assert len(left) <= most
    assert not {round(t, 3) for t in left} & {round(t, 3) for t in times}
    # ... and the outage left no hole in the track.
    during = [t for t in times if down_at <= t <= up_at]
    assert len(during) >= 12
    assert max(b - a for a, b in pairwise(during)) < 3 * float(PERIOD)


def test_the_f2414_modem_path_through_a_pty(live_server, boat, rig, tmp_path):
    vessel, key = boat
    modem = ModemStandIn(("127.0.0.1", urlsplit(live_server.url).port))
    config = tmp_path / "edge.toml"
    config.write_text(
        f'[transport]\nkind = "modem"\ntimeout_s = 10\n\n'
        f'[transport.modem]\nport = "{modem.device}"\nconnect_delay_s = 0.05\n'
    )
    try:
        rig.sim()
        rig.client(live_server.url, key, "--config", str(config))
        wait_until(lambda: Fix.objects.filter(vessel=vessel).count() >= 2, 30, "fixes via modem")
        command = command_enqueue(vessel=vessel, kind="hold", params={}, created_by="test")
        wait_until(lambda: command_status(command) in ("done", "failed"), 30, "hold via modem")
        assert command.status == "done", command.result_detail
        assert modem.sessions >= 3  # one connection per exchange, opened by "don"
        assert stop(rig.edge) == 0
    finally:
        modem.close()


@pytest.mark.parametrize("exchange", [True, False], ids=["exchange", "polls (exchange off)"])
def test_a_boat_reporting_every_round_never_polls_and_gets_a_command_within_a_round(
    live_server, boat, rig, tmp_path, exchange
):
    """One exchange per period (docs/api.md): the telemetry answers carry the command list,
    so once fixes flow every uplink round is one POST; a command queued meanwhile is handed
    over (marked sent) by the next round's answer. With the exchange off, the same boat polls
    every round (and the proxy is seen to count polls)."""
    vessel, key = boat
    round_s = 1.0  # several fixes (every PERIOD) in each round: no round without a report
    config = tmp_path / "edge.toml"
    config.write_text(f"[commands]\nexchange = {str(exchange).lower()}\n")
    proxy = TcpProxy(("127.0.0.1", urlsplit(live_server.url).port))
    rig.sim()
    rig.client(
        f"http://127.0.0.1:{proxy.port}", key, "--poll-period", str(round_s),
        "--telemetry-period", str(round_s), "--config", str(config),
    )  # fmt: skip
    try:
        wait_until(lambda: Fix.objects.filter(vessel=vessel).count() >= 3, 20, "fixes flowing")
        time.sleep(round_s)  # the round under way when the first fix landed is over
        before = len(proxy.requests())
        command = command_enqueue(vessel=vessel, kind="hold", params={}, created_by="test")
        wait_until(lambda: command_status(command) != "queued", 10, "the hold handed over")
        handed_after = (command.sent_at - command.created_at).total_seconds()
        wait_until(lambda: command_status(command) == "done", 20, "the hold done")
        time.sleep(3 * round_s)
        during = proxy.requests()[before:]
        assert stop(rig.edge) == 0
    finally:
        proxy.down()
    telemetry = [r for r in during if r == ("POST", "/api/v1/boat/telemetry/")]
    polls = [r for r in during if r == ("GET", "/api/v1/boat/commands/")]
    assert len(telemetry) >= 4, during
    assert (polls == []) if exchange else (len(polls) >= 4), (during, rig.log()[-2000:])
    assert ("POST", f"/api/v1/boat/commands/{command.uid}/ack/") in during
    # Within one round (and the request's own time on a shared test machine); by design at
    # most one round and a quarter (a round waiting for a fix a little late).
    assert handed_after <= round_s + 0.5, handed_after
