"""Chunked request bodies (fleet/chunked.py): read through a real gunicorn, 411 where the
server cannot find their end. A chunked body was once read as empty."""

from __future__ import annotations

import http.client
import io
import json
import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from fleet.chunked import LENGTH_REQUIRED_DETAIL, ChunkedBodyMiddleware, read_bounded
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import ROOT, start, stop, wait_until

LIMIT = 4096  # the server's DATA_UPLOAD_MAX_MEMORY_SIZE in the live tests
NOW = int(time.time())


def fixes(count: int) -> bytes:
    batch = [{"time": NOW - 60 + i, "lat": -31.95, "lon": 115.86 + i / 1000} for i in range(count)]
    return json.dumps({"fixes": batch}).encode()


# --- the middleware on its own ---------------------------------------------------------------


class Seen:
    """The wrapped application: remembers the body and length Django would have read."""

    def __init__(self) -> None:
        self.body: bytes | None = None
        self.length: str | None = None

    def __call__(self, environ: dict[str, Any], start_response: Any) -> list[bytes]:
        self.length = environ.get("CONTENT_LENGTH")
        self.body = environ["wsgi.input"].read(int(self.length or 0))
        start_response("200 OK", [])
        return [b"ok"]


def call(environ: dict[str, Any]) -> tuple[str, bytes, Seen]:
    seen = Seen()
    status: list[str] = []
    body = ChunkedBodyMiddleware(seen)(environ, lambda s, headers: status.append(s))
    return status[0], b"".join(body), seen


def chunked(body: bytes, **extra: Any) -> dict[str, Any]:
    return {"HTTP_TRANSFER_ENCODING": "chunked", "wsgi.input": io.BytesIO(body), **extra}


def test_a_chunked_body_is_handed_on_with_its_length(settings: Any) -> None:
    settings.DATA_UPLOAD_MAX_MEMORY_SIZE = 100
    status, _, seen = call(chunked(b"x" * 100, **{"wsgi.input_terminated": True}))
    assert status == "200 OK" and (seen.length, seen.body) == ("100", b"x" * 100)


def test_a_chunked_body_over_the_limit_is_cut_one_past_it_for_the_413(settings: Any) -> None:
    settings.DATA_UPLOAD_MAX_MEMORY_SIZE = 100
    _, _, seen = call(chunked(b"x" * 10_000, **{"wsgi.input_terminated": True}))
    assert seen.length == "101"


def test_a_chunked_body_the_server_cannot_end_is_a_411_saying_so() -> None:
    status, body, seen = call(chunked(b"5\r\nhello\r\n0\r\n\r\n"))
    assert status == "411 Length Required"
    assert json.loads(body) == {"error": "length_required", "detail": LENGTH_REQUIRED_DETAIL}
    assert seen.body is None


def test_a_declared_length_or_no_chunking_is_left_alone() -> None:
    _, _, seen = call(chunked(b"hello", CONTENT_LENGTH="5"))
    assert seen.body == b"hello"
    _, _, seen = call({"HTTP_TRANSFER_ENCODING": "gzip", "wsgi.input": io.BytesIO(b"")})
    assert seen.length is None


def test_read_bounded_reads_to_the_end_or_one_past_the_limit() -> None:
    assert read_bounded(io.BytesIO(b"a" * 200_000), None) == b"a" * 200_000
    assert read_bounded(io.BytesIO(b"a" * 200_000), 70_000) == b"a" * 70_001
    assert read_bounded(io.BytesIO(b""), 10) == b""


# --- through gunicorn ------------------------------------------------------------------------


class Server:
    """gunicorn serving fleet.wsgi:application on a SQLite file of its own."""

    def __init__(self, tmp: Path) -> None:
        self.env = {
            **os.environ,
            "DATABASE_URL": f"sqlite:///{tmp / 'db.sqlite3'}",
            "DATA_UPLOAD_MAX_MEMORY_SIZE": str(LIMIT),
            "PYTHONPATH": str(ROOT),
        }
        self.manage("migrate", "-v0")
        self.manage("create_vessel", "spab", "--name", "SPAB", "--kind", "mavlink")
        self.key = self.manage("issue_key", "spab").splitlines()[-1].strip()
        self.port = free_port(socket.SOCK_STREAM)
        saved = {k: os.environ.get(k) for k in ("DATABASE_URL", "DATA_UPLOAD_MAX_MEMORY_SIZE")}
        os.environ.update({k: self.env[k] for k in saved})
        try:
            self.proc = start(
                ["-m", "gunicorn", "fleet.wsgi:application", "-b", f"127.0.0.1:{self.port}",
                 "-w", "1"],
                tmp / "gunicorn.log",
            )  # fmt: skip
        finally:
            for name, value in saved.items():
                if value is None:
                    os.environ.pop(name, None)
                else:
                    os.environ[name] = value
        wait_until(self.answers, 30, "gunicorn to start")

    def manage(self, *args: str) -> str:
        done = subprocess.run(
            [sys.executable, "manage.py", *args],
            cwd=ROOT,
            env=self.env,
            capture_output=True,
            text=True,
            check=True,
        )
        return done.stdout

    def answers(self) -> bool:
        try:
            socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
        except OSError:
            return False
        return True

    def post_chunked(self, path: str, parts: list[bytes]) -> tuple[int, Any]:
        """POST ``parts`` as chunks, no Content-Length (http.client chunks an iterator)."""

        def body() -> Iterator[bytes]:
            yield from parts

        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=20)
        try:
            conn.request(
                "POST",
                path,
                body=body(),
                headers={
                    "Authorization": f"Api-Key {self.key}",
                    "Content-Type": "application/json",
                },
            )
            response = conn.getresponse()
            return response.status, json.loads(response.read())
        finally:
            conn.close()


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Server]:
    live = Server(tmp_path_factory.mktemp("chunked"))
    yield live
    stop(live.proc)


@pytest.mark.slow
def test_a_chunked_telemetry_batch_is_stored_through_gunicorn(server: Server) -> None:
    body = fixes(3)
    status, answer = server.post_chunked("/api/v1/boat/telemetry/", [body[:17], body[17:]])
    assert status == 200, answer
    assert answer == {"accepted": 3, "duplicates": 0, "rejected": []}


@pytest.mark.slow
def test_a_chunked_legacy_record_is_stored_through_gunicorn(server: Server) -> None:
    record = {"timestamp": NOW - 5, "latitude": -31.9, "longitude": 115.8, "temperature": 290}
    status, answer = server.post_chunked("/spab/data.cgi", [json.dumps(record).encode()])
    assert status == 200
    assert answer == [
        {"type": "telemAck"},
        {"success": "true", "message": "accepted 1, duplicates 0, rejected 0"},
    ]


@pytest.mark.slow
def test_a_chunked_body_over_the_limit_is_a_413_through_gunicorn(server: Server) -> None:
    body = fixes(100)
    assert len(body) > LIMIT
    status, answer = server.post_chunked("/api/v1/boat/telemetry/", [body[:3000], body[3000:]])
    assert status == 413 and answer["error"] == "too_large"
