"""The uplink policy (what leaves the outbox when) against a scripted stdlib HTTP server."""

from __future__ import annotations

import json
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from edge_client.client import EdgeClient
from edge_client.config import load_config
from edge_client.mavlink_link import MavlinkLink
from edge_client.outbox import Outbox
from edge_client.transports.http import HttpTransport


class Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"

    def _answer(self) -> None:
        length = int(self.headers.get("Content-Length") or 0)
        body = json.loads(self.rfile.read(length)) if length else None
        # The conditional header a test watches: the poll's If-None-Match unless it says.
        watched = self.headers.get(getattr(self.server, "log_header", "If-None-Match"))
        if self.path.endswith("/commands/"):
            watched = self.headers.get("If-None-Match")
        self.server.log.append((self.command, self.path, watched, body))
        status, headers, payload = self.server.respond(self.command, self.path, body, self.headers)
        data = json.dumps(payload).encode() if payload is not None else b""
        self.send_response(status)
        for name, value in headers.items():
            self.send_header(name, value)
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    do_GET = do_POST = _answer

    def log_message(self, *args) -> None:
        pass


def accept_all(method, path, body, headers):
    if path.endswith("/telemetry/"):
        return 200, {}, {"accepted": len(body["fixes"]), "duplicates": 0, "rejected": []}
    if path.endswith("/commands/"):
        return 200, {"ETag": '"v1"'}, {"commands": []}
    return 200, {}, {"uid": "x", "status": body["status"]}


@pytest.fixture
def server():
    srv = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    srv.log, srv.respond = [], accept_all
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    yield srv
    srv.shutdown()
    srv.server_close()


@pytest.fixture
def client(server, tmp_path):
    url = f"http://127.0.0.1:{server.server_address[1]}"
    config = load_config(None, {"server": url, "key": "k", "mavlink": "udpout:127.0.0.1:9",
                                "outbox": str(tmp_path / "o.sqlite3")})  # fmt: skip
    box = Outbox(config.outbox.path)
    c = EdgeClient(
        config,
        transport=HttpTransport(base_url=url, key="k", retries=0, backoff_s=0),
        link=MavlinkLink(config.mavlink),
        outbox=box,
    )
    yield c
    box.close()


def fix(n: int, **extra) -> dict:
    return {"time": f"2026-11-23T10:00:{n:02d}.000+00:00", "lat": 1.0, "lon": 2.0, **extra}


def telemetry_posts(server) -> list[list[dict]]:
    return [b["fixes"] for m, p, _, b in server.log if p.endswith("/telemetry/")]


def test_fixes_go_in_batches_and_leave_when_accepted(client, server):
    for n in range(120):
        client.outbox.add_fix(fix(n % 60, lat=1 + n))
    client.uplink_once(0.0)
    assert [len(b) for b in telemetry_posts(server)] == [50, 50, 20]
    assert client.outbox.count("fix") == 0 and client.server_ok is True


def test_rejected_fixes_are_dropped_and_counted(client, server):
    def respond(method, path, body, headers):
        if path.endswith("/telemetry/"):
            rejected = [{"index": 1, "errors": {"lat": "out of range"}}]
            return 200, {}, {"accepted": 2, "duplicates": 0, "rejected": rejected}
        return accept_all(method, path, body, headers)

    server.respond = respond
    for n in range(3):
        client.outbox.add_fix(fix(n))
    client.uplink_once(0.0)
    assert client.outbox.count("fix") == 0
    assert client.outbox.counter("rejected_fixes") == 1


def test_an_answer_that_does_not_add_up_keeps_the_fixes(client, server):
    server.respond = lambda m, p, b, h: (200, {}, {"accepted": 0, "duplicates": 0, "rejected": []})
    client.outbox.add_fix(fix(1))
    client.uplink_once(0.0)
    assert client.outbox.count("fix") == 1


def test_a_bad_key_keeps_everything_queued(client, server):
    server.respond = lambda m, p, b, h: (401, {}, {"error": "authentication_failed", "detail": "x"})
    client.outbox.add_fix(fix(1))
    client.outbox.add_ack("u1", "done")
    wait = client.uplink_once(0.0)
    assert client.outbox.count() == 2 and client.server_ok is False
    assert wait > client.config.commands.poll_period_s  # backs off


def test_a_malformed_fix_is_isolated_by_splitting_the_batch(client, server):
    def respond(method, path, body, headers):
        if path.endswith("/telemetry/") and any("poison" in f for f in body["fixes"]):
            return 400, {}, {"error": "parse_error", "detail": "malformed"}
        return accept_all(method, path, body, headers)

    server.respond = respond
    for n in range(8):
        client.outbox.add_fix(fix(n, **({"poison": 1} if n == 5 else {})))
    client.uplink_once(0.0)
    assert client.outbox.count("fix") == 0
    assert client.outbox.counter("rejected_fixes") == 1
    sent = [f["time"] for batch in telemetry_posts(server) for f in batch if "poison" not in f]
    assert sorted(set(sent)) == sorted(fix(n)["time"] for n in range(8) if n != 5)


@pytest.mark.parametrize(("status", "kept"), [(404, 0), (409, 0), (500, 1)])
def test_acks_the_server_will_never_take_are_dropped(client, server, status, kept):
    server.respond = lambda m, p, b, h: (status, {}, {"error": "x", "detail": "y"})
    client.outbox.add_ack("u1", "done", "arrived")
    client.uplink_once(0.0)
    assert client.outbox.count("ack") == kept
    assert ("POST", "/api/v1/boat/commands/u1/ack/", None,
            {"status": "done", "detail": "arrived"}) in server.log  # fmt: skip


def ack_posts(server) -> list[dict]:
    return [b for m, p, _, b in server.log if p.endswith("/ack/")]


def test_a_superseded_ack_goes_up_as_superseded(client, server):
    client.outbox.add_ack("u1", "superseded", "replaced by hold command u2")
    client.uplink_once(0.0)
    assert ack_posts(server) == [{"status": "superseded", "detail": "replaced by hold command u2"}]
    assert client.outbox.count("ack") == 0


def test_a_server_without_superseded_gets_failed_instead(client, server):
    def older_server(method, path, body, headers):  # before superseded was an ack status
        if path.endswith("/ack/") and body["status"] not in ("acknowledged", "done", "failed"):
            detail = {"status": ["status must be acknowledged, done or failed"]}
            return 400, {}, {"error": "invalid", "detail": detail}
        return accept_all(method, path, body, headers)

    server.respond = older_server
    client.outbox.add_ack("u1", "superseded", "replaced by hold command u2")
    client.uplink_once(0.0)
    assert ack_posts(server) == [
        {"status": "superseded", "detail": "replaced by hold command u2"},
        {"status": "failed", "detail": "replaced by hold command u2"},  # so it does not stay open
    ]
    assert client.outbox.count("ack") == 0 and client.outbox.counter("dropped_acks") == 0


@pytest.mark.parametrize(("status", "kept"), [(409, 0), (500, 1)])
def test_a_superseded_ack_refused_otherwise_is_not_resent_as_failed(client, server, status, kept):
    server.respond = lambda m, p, b, h: (status, {}, {"error": "x", "detail": "y"})
    client.outbox.add_ack("u1", "superseded", "replaced")
    client.uplink_once(0.0)
    assert [b["status"] for b in ack_posts(server)] == ["superseded"]
    assert client.outbox.count("ack") == kept


def test_polls_send_the_etag_and_new_commands_reach_the_executor(client, server):
    def respond(method, path, body, headers):
        if path.endswith("/commands/"):
            if headers.get("If-None-Match") == '"v2"':
                return 304, {"ETag": '"v2"'}, None
            return 200, {"ETag": '"v2"'}, {"commands": [
                {"uid": "c1", "kind": "hold", "params": {}, "created_at": "2026-11-23T10:00:00Z",
                 "expires_at": None}]}  # fmt: skip
        return accept_all(method, path, body, headers)

    server.respond = respond
    client.uplink_once(0.0)
    client.uplink_once(100.0)
    polls = [(etag) for m, p, etag, _ in server.log if p.endswith("/commands/")]
    assert polls == [None, '"v2"']
    assert client.executor._queue.qsize() == 1  # queued once, from the first poll only


def test_check_says_both_links_are_fine(server, make_sim, capsys):
    from edge_client.cli import main

    sim = make_sim()
    url = f"http://127.0.0.1:{server.server_address[1]}"
    assert main(["check", "--server", url, "--key", "k", "--mavlink", sim.endpoint]) == 0
    out = capsys.readouterr().out
    assert "autopilot: OK  system 1" in out and "mode HOLD, disarmed" in out
    assert "server: OK" in out and "vessel key accepted" in out
    # The check leaves the boat's commands alone: no poll, just an empty telemetry batch.
    assert [(m, p) for m, p, *_ in server.log] == [("POST", "/api/v1/boat/telemetry/")]


def test_check_names_the_link_that_fails(server, capsys):
    from edge_client.cli import main

    server.respond = lambda m, p, b, h: (401, {}, {"error": "authentication_failed", "detail": ""})
    url = f"http://127.0.0.1:{server.server_address[1]}"
    argv = ["check", "--server", url, "--key", "bad", "--mavlink", "udpout:127.0.0.1:9",
            "--timeout", "1"]  # fmt: skip
    assert main(argv) == 1
    out = capsys.readouterr().out
    assert "autopilot: FAILED  no HEARTBEAT within 1 s on udpout:127.0.0.1:9" in out
    assert "server: FAILED" in out and "refused the vessel key (HTTP 401" in out


# --- one exchange per period: the telemetry answer carries the command list ---

HOLD = {"uid": "c1", "kind": "hold", "params": {}, "created_at": "2026-11-23T10:00:00Z",
        "expires_at": None}  # fmt: skip


def exchanging(method, path, body, headers):
    """A server that answers X-Commands-ETag: the list (one hold) until the boat holds "v2",
    then 204 No Content (every fix taken, the list current), as the real one does."""
    minimal = headers.get("Prefer") == "return=minimal"
    if path.endswith("/telemetry/") and headers.get("X-Commands-ETag") == '"v2"' and minimal:
        return 204, {}, None
    if path.endswith("/telemetry/") and headers.get("X-Commands-ETag") is not None:
        answer = {"accepted": len(body["fixes"]), "duplicates": 0, "rejected": []}
        answer["commands_etag"] = '"v2"'
        if headers["X-Commands-ETag"] != '"v2"':
            answer["commands"] = [HOLD]
        return 200, {}, answer
    if path.endswith("/commands/"):
        if headers.get("If-None-Match") == '"v2"':
            return 304, {"ETag": '"v2"'}, None
        return 200, {"ETag": '"v2"'}, {"commands": [HOLD]}
    return accept_all(method, path, body, headers)


def exchange_tags(server) -> list:
    return [h for m, p, h, _ in server.log if p.endswith("/telemetry/")]


def polls(server) -> int:
    return sum(p.endswith("/commands/") for m, p, *_ in server.log)


def test_a_boat_that_reports_every_round_takes_its_commands_without_polling(client, server):
    server.respond = exchanging
    server.log_header = "X-Commands-ETag"
    for n in range(3):
        client.outbox.add_fix(fix(n))
        client.uplink_once(n * 100.0)  # every round past its poll's due time
    assert polls(server) == 0
    assert exchange_tags(server) == ['""', '"v2"', '"v2"']  # none held, then the one given
    assert client.executor._queue.qsize() == 1
    assert client.outbox.count("fix") == 0


def test_a_round_with_nothing_to_send_polls(client, server):
    server.respond = exchanging
    server.log_header = "X-Commands-ETag"
    client.outbox.add_fix(fix(1))
    client.uplink_once(0.0)
    client.uplink_once(5.0)  # nothing queued, the poll not due yet (10 s)
    assert polls(server) == 0
    client.uplink_once(10.5)
    assert polls(server) == 1
    # The poll sends the tag the telemetry answer gave: nothing new, a 304 from a real server.
    assert [h for m, p, h, _ in server.log if p.endswith("/commands/")] == ['"v2"']
    assert client.etag == '"v2"'


def test_an_older_server_gets_the_poll_as_ever(client, server):
    """Its answer has no commands_etag: the header was not understood."""
    client.outbox.add_fix(fix(1))
    client.uplink_once(0.0)
    client.outbox.add_fix(fix(2))
    client.uplink_once(20.0)
    assert polls(server) == 2


def test_with_the_exchange_off_no_header_is_sent(client, server):
    server.respond = exchanging
    server.log_header = "X-Commands-ETag"
    client.exchange = False
    client.outbox.add_fix(fix(1))
    client.uplink_once(0.0)
    assert exchange_tags(server) == [None]
    assert polls(server) == 1


def test_a_round_just_before_the_next_fix_waits_for_it_once_rather_than_poll(client, server):
    """Sampling and uplink on clocks of their own (10 s each by default): a round that comes
    just before its fix puts itself after the fix, so the exchange still saves the poll."""
    server.respond = exchanging
    client.outbox.add_fix(fix(1))
    client.uplink_once(0.0)  # an exchange: the next round is due at 10
    client._sampled_at = 0.1  # the fix of 0.1 went; the next one comes at 10.1
    client.uplink_once(10.0)  # not a poll now: a round at 10.1 + 2.5 (a quarter period late)
    assert polls(server) == 0 and client._next_poll == pytest.approx(12.6)
    client.outbox.add_fix(fix(2))
    client._sampled_at = 10.1
    client.uplink_once(10.3)
    assert polls(server) == 0 and len(telemetry_posts(server)) == 2
    client.uplink_once(20.3)  # no fix since 10.1 (the autopilot went silent): a poll
    assert polls(server) == 1
    client._sampled_at = 20.5  # a fix due at 30.5...
    client.uplink_once(30.3)  # ...so this round waits for it, until 33.0
    assert polls(server) == 1 and client._next_poll == pytest.approx(33.0)
    client.uplink_once(33.0)  # it is not there: a poll, never a second wait in a row
    assert polls(server) == 2


def test_a_round_sends_what_was_queued_when_it_read_and_no_more(client, server):
    """A fix sampled during the round's post waits for the next round: one request a round."""
    client.outbox.add_fix(fix(1))
    real_send = client._send_fixes

    def send_while_a_fix_comes(items):
        client.outbox.add_fix(fix(2))  # sampled while the post is on its way
        return real_send(items)

    client._send_fixes = send_while_a_fix_comes
    client.flush_fixes()
    assert telemetry_posts(server) == [[fix(1)]]
    assert client.outbox.count("fix") == 1
