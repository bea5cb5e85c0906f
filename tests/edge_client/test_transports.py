"""Both transports against small local stand-ins: a stdlib HTTP server and a pty "modem"."""

from __future__ import annotations

import json
import os
import pty
import threading
import time
import tty
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

from edge_client.transports.base import TransportError, with_retries
from edge_client.transports.http import HttpTransport
from edge_client.transports.modem import ModemTransport


class Recorder(BaseHTTPRequestHandler):
    """Answers from ``server.script`` (a list of (status, headers, body)), records requests."""

    protocol_version = "HTTP/1.1"

    def _answer(self) -> None:
        length = int(self.headers.get("Content-Length") or 0)
        body = self.rfile.read(length) if length else b""
        self.server.requests.append((self.command, self.path, dict(self.headers), body))
        status, headers, payload = self.server.script.pop(0) if self.server.script else (
            200, {}, b"{}")  # fmt: skip
        self.send_response(status)
        for name, value in headers.items():
            self.send_header(name, value)
        self.send_header("Content-Length", str(len(payload)))
        self.end_headers()
        self.wfile.write(payload)

    do_GET = do_POST = _answer

    def log_message(self, *args) -> None:
        pass


@pytest.fixture
def http_server():
    server = ThreadingHTTPServer(("127.0.0.1", 0), Recorder)
    server.requests, server.script = [], []
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()


def url(server) -> str:
    return f"http://127.0.0.1:{server.server_address[1]}"


def test_http_posts_json_with_the_key(http_server):
    http_server.script = [(200, {}, b'{"accepted": 1, "duplicates": 0, "rejected": []}')]
    transport = HttpTransport(base_url=url(http_server), key="k1", backoff_s=0)
    response = transport.post_json("/api/v1/boat/telemetry/", {"fixes": [{"lat": 1}]})
    assert response.json()["accepted"] == 1
    method, path, headers, body = http_server.requests[0]
    assert (method, path) == ("POST", "/api/v1/boat/telemetry/")
    assert headers["Authorization"] == "Api-Key k1"
    assert json.loads(body) == {"fixes": [{"lat": 1}]}


def test_http_sends_only_the_headers_the_server_needs(http_server):
    """Every byte is paid for on 3G: no User-Agent, Accept, Accept-Encoding or Connection
    (requests, urllib3 and http.client each add some by default)."""
    transport = HttpTransport(base_url=url(http_server), key="k1", backoff_s=0)
    transport.post_json("/t/", {"fixes": []}, {"X-Commands-ETag": '"c1.2"'})
    transport.get("/c/", '"c1.2"')
    transport.get("/c/")
    names = [list(headers) for _, _, headers, _ in http_server.requests]
    assert names == [
        ["Host", "Authorization", "Content-Type", "X-Commands-ETag", "Content-Length"],
        ["Host", "Authorization", "If-None-Match"],
        ["Host", "Authorization"],
    ]


def test_http_get_sends_if_none_match_and_takes_a_304(http_server):
    http_server.script = [
        (200, {"ETag": '"v1"'}, b'{"commands": []}'),
        (304, {"ETag": '"v1"'}, b""),
    ]
    transport = HttpTransport(base_url=url(http_server), key="k", backoff_s=0)
    first = transport.get("/c/")
    assert first.etag == '"v1"'
    second = transport.get("/c/", first.etag)
    assert second.status == 304 and second.body == b""
    assert http_server.requests[1][2]["If-None-Match"] == '"v1"'


def test_http_4xx_is_permanent_and_not_retried(http_server):
    http_server.script = [(401, {}, b'{"error": "bad_key", "detail": "Invalid key."}')]
    transport = HttpTransport(base_url=url(http_server), key="wrong", retries=3, backoff_s=0)
    with pytest.raises(TransportError) as info:
        transport.get("/c/")
    assert info.value.permanent and info.value.status == 401
    assert "bad_key" in str(info.value)
    assert len(http_server.requests) == 1


def test_http_5xx_is_retried_with_backoff_then_temporary(http_server):
    http_server.script = [(503, {}, b"")] * 2 + [(200, {}, b"{}")]
    transport = HttpTransport(base_url=url(http_server), key="k", retries=2, backoff_s=0.01)
    assert transport.get("/c/").status == 200
    http_server.script = [(500, {}, b"")] * 3
    with pytest.raises(TransportError) as info:
        transport.get("/c/")
    assert not info.value.permanent and info.value.status == 500


def test_http_refused_connection_is_temporary():
    transport = HttpTransport(base_url="http://127.0.0.1:9", key="k", retries=0, timeout_s=1)
    with pytest.raises(TransportError) as info:
        transport.get("/c/")
    assert not info.value.permanent


def test_tls_verification_is_on():
    assert HttpTransport(base_url="https://x", key="k").session.verify is True


def test_with_retries_doubles_the_pause():
    pauses = []
    calls = iter([TransportError("a"), TransportError("b"), "ok"])

    def attempt():
        value = next(calls)
        if isinstance(value, Exception):
            raise value
        return value

    assert with_retries(attempt, retries=3, backoff_s=0.5, sleep=pauses.append) == "ok"
    assert pauses == [0.5, 1.0]


# -- the F2414 modem through a pseudo-terminal pair ---------------------------------------------


class FakeModem:
    """Plays the modem on the pty master: waits for ``don``, reads one HTTP request, answers
    with ``answer`` in the given chunk sizes (then goes quiet, as after the server closed)."""

    def __init__(self, answer: bytes, chunks: list[int] | None = None) -> None:
        self.master, slave = pty.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        self._slave = slave
        self.answer, self.chunks = answer, chunks
        self.received = b""
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _read_request(self) -> bytes:
        data = b""
        while b"\r\n\r\n" not in data:
            data += os.read(self.master, 4096)
        head, _, body = data.partition(b"\r\n\r\n")
        length = 0
        for line in head.split(b"\r\n"):
            if line.lower().startswith(b"content-length:"):
                length = int(line.split(b":")[1])
        while len(body) < length:
            body += os.read(self.master, 4096)
        return data

    def _run(self) -> None:
        buf = b""
        while b"don" not in buf:
            buf += os.read(self.master, 64)
        self.received = self._read_request()
        sizes = self.chunks or [len(self.answer)]
        pos = 0
        for size in sizes:
            os.write(self.master, self.answer[pos : pos + size])
            pos += size
            time.sleep(0.05)

    def close(self) -> None:
        self._thread.join(5)
        os.close(self.master)
        os.close(self._slave)


def modem(port: str) -> ModemTransport:
    return ModemTransport(base_url="http://shore.example.org:8000", key="k9", port=port,
                          connect_delay_s=0.05, timeout_s=3, retries=0)  # fmt: skip


ANSWER = b'HTTP/1.1 200 OK\r\nETag: "e2"\r\nContent-Length: 16\r\n\r\n{"commands": []}'


def test_modem_writes_the_trigger_then_a_correct_request():
    fake = FakeModem(b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\n{}")
    transport = modem(fake.path)
    response = transport.post_json("/api/v1/boat/telemetry/", {"fixes": []})
    transport.close()
    fake.close()
    assert response.status == 200 and response.json() == {}
    request = fake.received
    assert request.startswith(b"POST /api/v1/boat/telemetry/ HTTP/1.1\r\n")
    assert b"\r\nHost: shore.example.org:8000\r\n" in request
    assert b"\r\nAuthorization: Api-Key k9\r\n" in request
    assert b"\r\nContent-Length: 12\r\n" in request
    assert request.endswith(b'\r\n\r\n{"fixes":[]}')
    names = [line.split(b":")[0] for line in request.split(b"\r\n\r\n")[0].split(b"\r\n")[1:]]
    # Connection: close is the modem's: one exchange per connection (transports/modem.py).
    assert names == [b"Host", b"Connection", b"Authorization", b"Content-Type", b"Content-Length"]


def test_modem_reassembles_an_answer_split_across_reads():
    fake = FakeModem(ANSWER, chunks=[7, 1, 20, 3, 100])
    transport = modem(fake.path)
    response = transport.get("/api/v1/boat/commands/", '"e1"')
    transport.close()
    fake.close()
    assert response.etag == '"e2"' and response.json() == {"commands": []}
    assert b'If-None-Match: "e1"\r\n' in fake.received


def test_modem_answer_cut_short_is_a_temporary_error():
    fake = FakeModem(ANSWER[:-5])
    transport = modem(fake.path)
    with pytest.raises(TransportError) as info:
        transport.get("/api/v1/boat/commands/")
    transport.close()
    fake.close()
    assert not info.value.permanent and "ended after" in str(info.value)


def test_modem_http_errors_map_like_http():
    fake = FakeModem(b'HTTP/1.1 409 Conflict\r\nContent-Length: 20\r\n\r\n{"error": "illegal"}')
    transport = modem(fake.path)
    with pytest.raises(TransportError) as info:
        transport.post_json("/api/v1/boat/commands/u/ack/", {"status": "done"})
    transport.close()
    fake.close()
    assert info.value.permanent and info.value.status == 409


def test_modem_port_missing_is_temporary():
    with pytest.raises(TransportError) as info:
        modem("/dev/does-not-exist").get("/x/")
    assert not info.value.permanent
