"""The SBD fallback link: the pure choices, then the ``sbd`` thread and a real EdgeClient
against the SBD simulator on a pty and an HTTP shore that is down (a closed port) or up."""

from __future__ import annotations

import json
import logging
import socket
import threading
import time
import uuid
from collections.abc import Iterator
from http.server import ThreadingHTTPServer

import pytest

from edge_client.client import EdgeClient
from edge_client.commands import Command
from edge_client.config import SbdLinkConfig, load_config
from edge_client.contract import compact, compact_command
from edge_client.mavlink_link import MavlinkLink
from edge_client.outbox import Item, Outbox
from edge_client.sbd.simulator import SbdModemServer, SimulatedSbdModem, control
from edge_client.sbd_fallback import SbdFallback, command_from_mt, fallback_due, pick_fixes
from edge_client.transports.http import HttpTransport
from tests.edge_client.helpers import wait_until
from tests.edge_client.test_client import Handler, accept_all

CHANNELS = compact.channels_from([{"name": "water_temp_c", "step": 0.01}])
T0 = 1_795_000_000  # 2026-11-18, a steady 10 s period below


def fix(n: int, **extra) -> dict:
    """The n-th fix of a boat heading north-east at a steady pace, milliseconds in its time."""
    return {
        "time": T0 + 10 * n + 0.123,
        "lat": 55.0 + n * 1e-4,
        "lon": 12.0 + n * 1e-4,
        "heading_deg": 45.0,
        "speed_mps": 1.5,
        "battery_v": 12.6,
        "readings": {"water_temp_c": 8.0 + n / 100, "armed": 1},
        **extra,
    }


def items(count: int) -> list[Item]:
    """Outbox items, newest first (as Outbox.newest gives them)."""
    return [Item(id=n + 1, kind="fix", body=fix(n)) for n in reversed(range(count))]


# -- pure ---------------------------------------------------------------------------------------


def test_the_newest_fixes_that_fit_go_in_time_order():
    payload, chosen = pick_fixes(items(200), CHANNELS)
    assert len(payload) <= 340
    decoded = compact.decode(payload, CHANNELS)
    count = len(decoded)
    assert 20 < count < 200  # not all: the newest that fit
    assert [i.id for i in chosen] == list(range(200 - count + 1, 201))  # the newest, oldest first
    assert [round(f["lat"], 4) for f in decoded] == [round(i.body["lat"], 4) for i in chosen]
    # One more fix would not have fitted.
    one_more = items(200)[: count + 1]
    assert len(compact.encode([i.body for i in one_more], CHANNELS, drop_unknown=True)) > 340


def test_a_fix_the_compact_form_refuses_is_left_to_http():
    fixes = items(5)
    fixes[1] = Item(id=fixes[1].id, kind="fix", body=fix(3, lat=123.0))
    _payload, chosen = pick_fixes(fixes, CHANNELS)
    assert [i.id for i in chosen] == [1, 2, 3, 5]
    assert pick_fixes([fixes[1]], CHANNELS) is None
    assert pick_fixes([], CHANNELS) is None


@pytest.mark.parametrize(
    ("failing_for", "since_last", "due"),
    [
        (None, None, False),  # HTTP works
        (30.0, None, False),  # failing, not long enough
        (61.0, None, True),  # long enough: the first message at once
        (61.0, 100.0, False),  # the last one was less than a period ago
        (61.0, 900.0, True),
    ],
)
def test_when_the_fallback_message_is_due(failing_for, since_last, due):
    config = SbdLinkConfig(port="x", fallback_after_s=60, period_s=900)
    assert fallback_due(failing_for, since_last, config) is due


def test_an_mt_message_is_the_command_it_carries():
    uid = str(uuid.uuid4())
    items_ = [{"lat": 55.5, "lon": 12.5, "hold_s": None, "radius_m": 3.0, "speed_mps": None}]
    data = compact_command.encode(uid, "mission", {"items": items_, "loop": None})
    command = command_from_mt(data)
    assert (command.uid, command.kind) == (uid, "mission")
    assert command.params == {"items": items_}  # left out: absent, as in a polled command
    with pytest.raises(ValueError, match="not a command of this form"):
        command_from_mt(b"hello from the shore, not a command")


# -- the sbd thread against the simulator -------------------------------------------------------


@pytest.fixture
def sim() -> SimulatedSbdModem:
    return SimulatedSbdModem()


@pytest.fixture
def modem_port(sim: SimulatedSbdModem) -> Iterator[str]:
    with SbdModemServer(sim) as server:
        yield server.url


def modem_ready(sim: SimulatedSbdModem) -> bool:
    return "AT+SBDMTA=1" in sim.commands  # set up, ring alerts on: a ring now reaches it


class Fallback:
    """An SbdFallback thread with HTTP failing (or not) as the test says."""

    def __init__(self, port: str, outbox: Outbox, failing_for: float | None, **config) -> None:
        self.failing = failing_for
        self.commands: list[Command] = []
        self.stop = threading.Event()
        settings = {"fallback_after_s": 0.0, "period_s": 3600.0, **config}
        self.link = SbdFallback(
            SbdLinkConfig(port=port, **settings),
            CHANNELS,
            outbox,
            failing_for=lambda now: self.failing,
            on_command=lambda c: self.commands.append(c) or True,
            stop=self.stop,
        )
        self.link.start()

    def close(self) -> None:
        self.stop.set()
        self.link.join(5)


@pytest.fixture
def fallbacks() -> Iterator:
    made: list[Fallback] = []

    def make(*args, **kwargs) -> Fallback:
        made.append(Fallback(*args, **kwargs))
        return made[-1]

    yield make
    for fallback in made:
        fallback.close()


def test_garbage_from_the_shore_is_logged_and_dropped(sim, modem_port, outbox, fallbacks, caplog):
    caplog.set_level(logging.INFO, "edge_client.sbd_fallback")
    link = fallbacks(modem_port, outbox, failing_for=None)
    wait_until(lambda: modem_ready(sim), 5, "the modem set up")
    uid = str(uuid.uuid4())
    control(sim, "mt not a command")
    sim.queue_mt(compact_command.encode(uid, "hold", {}), ring=False)  # waits behind it
    wait_until(lambda: link.commands, 5, "the command behind the garbage")
    assert [c.uid for c in link.commands] == [uid]
    assert outbox.counter("sbd_dropped_mt") == 1
    assert "no command" in caplog.text
    assert sim.delivered == []  # HTTP works: mailbox checks only, no fixes
    assert link.link.is_alive()


def test_fix_times_are_whole_seconds_before_the_session_not_after_it(
    sim, modem_port, outbox, fallbacks
):
    """A session can take a minute: an uplink round that posts these fixes meanwhile must
    already send the times the SBD message carries, or the shore would keep both copies."""
    for n in range(3):
        outbox.add_fix(fix(n))
    sim.network = False  # no sky: the session retries and nothing is delivered yet
    fallbacks(modem_port, outbox, failing_for=10.0)
    wait_until(lambda: "AT+SBDIX" in sim.commands, 5, "a session under way")
    times = [item.body["time"] for item in outbox.peek("fix", 10)]
    assert times == [T0, T0 + 10, T0 + 20] and sim.delivered == []


def test_a_permanent_failure_ends_sbd_with_one_error(sim, modem_port, outbox, fallbacks, caplog):
    outbox.add_fix(fix(0))
    sim.fail_codes.append(15)  # access denied: no subscription
    link = fallbacks(modem_port, outbox, failing_for=10.0)
    wait_until(lambda: link.link.disabled, 5, "SBD to give up")
    link.link.join(5)
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert len(errors) == 1
    assert errors[0].getMessage().startswith("SBD disabled until the client restarts: ")
    assert "15 (access is denied" in errors[0].getMessage()
    assert link.link.is_alive()  # no fault of the client's: the watchdog keeps being fed
    assert sim.delivered == []


# -- a real EdgeClient --------------------------------------------------------------------------


def closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Shore:
    """The test_client HTTP stand-in on a port of our choosing, started when the test says."""

    def __init__(self, port: int, respond=accept_all) -> None:
        self.port = port
        self.url = f"http://127.0.0.1:{port}"
        self.respond = respond
        self.srv: ThreadingHTTPServer | None = None

    def up(self) -> None:
        self.srv = ThreadingHTTPServer(("127.0.0.1", self.port), Handler)
        self.srv.log, self.srv.respond = [], self.respond
        threading.Thread(target=self.srv.serve_forever, daemon=True).start()

    @property
    def log(self) -> list:
        return self.srv.log if self.srv else []

    def down(self) -> None:
        if self.srv:
            self.srv.shutdown()
            self.srv.server_close()


@pytest.fixture
def shore() -> Iterator[Shore]:
    shore = Shore(closed_port())
    yield shore
    shore.down()


@pytest.fixture
def start_client(tmp_path) -> Iterator:
    running: list[tuple[EdgeClient, threading.Thread, Outbox]] = []

    def start(shore: Shore, modem_port: str, fixes: int = 0, **sbd) -> EdgeClient:
        settings = {"fallback_after_s": 0.5, "period_s": 3600, **sbd}
        table = "".join(f"{k} = {json.dumps(v)}\n" for k, v in settings.items())
        path = tmp_path / "edge.toml"
        path.write_text(
            f'[server]\nurl = "{shore.url}"\nkey = "k"\n'
            '[mavlink]\nconnection = "udpout:127.0.0.1:9"\n'
            '[telemetry]\nperiod_s = 3600\nchannels = [{name = "water_temp_c", step = 0.01}]\n'
            "[commands]\npoll_period_s = 0.1\nready_timeout_s = 0.2\n"
            f'[outbox]\npath = "{tmp_path / "outbox.sqlite3"}"\n'
            f'[sbd]\nport = "{modem_port}"\n{table}'
        )
        config = load_config(path)
        box = Outbox(config.outbox.path)
        for n in range(fixes):
            box.add_fix(fix(n))
        client = EdgeClient(
            config,
            transport=HttpTransport(base_url=shore.url, key="k", retries=0, backoff_s=0),
            link=MavlinkLink(config.mavlink),
            outbox=box,
        )
        thread = threading.Thread(target=client.run, daemon=True)
        thread.start()
        running.append((client, thread, box))
        return client

    yield start
    for client, thread, box in running:
        client.stop_event.set()
        thread.join(10)
        box.close()


def test_http_down_past_fallback_after_s_sends_the_newest_fixes_by_sbd(
    sim, modem_port, shore, start_client
):
    client = start_client(shore, modem_port, fixes=200)
    wait_until(lambda: sim.delivered, 8, "an MO message at the gateway")
    (payload,) = sim.delivered
    decoded = compact.decode(payload, CHANNELS)
    count = len(decoded)
    assert 20 < count < 200 and len(payload) <= 340
    newest = [fix(n) for n in range(200 - count, 200)]
    assert [f["lat"] for f in decoded] == pytest.approx([f["lat"] for f in newest], abs=2e-5)
    assert [f["readings"]["water_temp_c"] for f in decoded] == pytest.approx(
        [f["readings"]["water_temp_c"] for f in newest]
    )
    # They stay queued for HTTP, now with the whole seconds the shore got by SBD: when HTTP
    # returns, the shore counts each of them a duplicate.
    assert client.outbox.count("fix") == 200
    queued = client.outbox.peek("fix", 200)
    sent_times = [T0 + 10 * n for n in range(200 - count, 200)]
    assert [i.body["time"] for i in queued[-count:]] == sent_times
    assert queued[0].body["time"] == T0 + 0.123  # not sent by SBD: untouched
    assert client.http_failing_for(time.monotonic()) > 0.5 and client.sbd.sessions == 1


def test_a_command_by_sbd_runs_once_though_http_brings_it_again(
    sim, modem_port, shore, start_client
):
    uid = str(uuid.uuid4())
    client = start_client(shore, modem_port, fallback_after_s=3600)
    wait_until(lambda: modem_ready(sim), 5, "the modem set up")
    control(sim, "mthex " + compact_command.encode(uid, "hold", {}).hex())
    # No autopilot here: the hold fails at once, and its ack waits in the outbox for HTTP.
    wait_until(lambda: client.outbox.count("ack") == 1, 5, "the command to run and be acked")
    assert client.executor.executed == [uid]
    assert sim.delivered == [] and len(sim.received) == 1  # a mailbox check answered the ring

    def same_command_again(method, path, body, headers):
        if path.endswith("/commands/"):
            return 200, {"ETag": '"v1"'}, {"commands": [{"uid": uid, "kind": "hold", "params": {}}]}
        return accept_all(method, path, body, headers)

    shore.respond = same_command_again
    shore.up()
    client._kick.set()  # the uplink may be deep in its outage backoff
    polls = lambda: [e for e in shore.log if e[1].endswith("/commands/")]  # noqa: E731
    wait_until(lambda: len(polls()) >= 2, 8, "two polls that list the command")
    assert client.executor.executed == [uid]  # once
    acks = [(p, b["status"]) for m, p, _, b in shore.log if "/ack/" in p]
    assert acks == [(f"/api/v1/boat/commands/{uid}/ack/", "failed")]
    assert client.outbox.count("ack") == 0


def test_with_http_healthy_sbd_stays_quiet_unless_the_modem_rings(
    sim, modem_port, shore, start_client
):
    shore.up()
    client = start_client(shore, modem_port, fixes=30, fallback_after_s=0.1, period_s=0.1)
    wait_until(lambda: modem_ready(sim), 5, "the modem set up")
    # Many uplink rounds, each well past fallback_after_s: HTTP works, so no session.
    polls = lambda: [e for e in shore.log if e[1].endswith("/commands/")]  # noqa: E731
    wait_until(lambda: len(polls()) >= 20, 8, "twenty polls")
    assert client.outbox.count("fix") == 0 and sim.received == []
    uid = str(uuid.uuid4())
    sim.queue_mt(compact_command.encode(uid, "hold", {}))  # an urgent command: it rings
    wait_until(lambda: client.executor.executed, 5, "the command from the ring")
    assert client.executor.executed == [uid]
    assert [m.data for m in sim.received] == [b""]  # one mailbox check, no fixes
    assert "AT+SBDIXA" in sim.commands


def test_http_counts_as_failing_from_its_last_good_exchange(shore, tmp_path):
    config = load_config(None, {"server": shore.url, "key": "k", "mavlink": "udpout:127.0.0.1:9",
                                "outbox": str(tmp_path / "o.sqlite3")})  # fmt: skip
    box = Outbox(config.outbox.path)
    client = EdgeClient(
        config,
        transport=HttpTransport(base_url=shore.url, key="k", retries=0, backoff_s=0),
        link=MavlinkLink(config.mavlink),
        outbox=box,
    )
    assert client.sbd is None  # no [sbd] port: no modem, no thread
    client.uplink_once(time.monotonic())  # the port is closed: a failure, the first one
    first = time.monotonic()
    assert 0 <= client.http_failing_for(first) < 5
    shore.up()
    before = time.monotonic()
    client.uplink_once(before)
    after = time.monotonic()
    assert client.http_failing_for(after) is None
    shore.srv.respond = lambda *_: (503, {}, None)  # down again
    client.uplink_once(time.monotonic() + 1000)  # a poll is due again
    # Failing since the good exchange, not since this round.
    assert after - before + 100 >= client.http_failing_for(after + 100) >= 100 - (after - before)
    box.close()
