"""Vessel keys never reach the logs (fleet/logs.py, fleet/gunicorn_logging.py): a legacy boat's
`?key=` and a refused v1 one, through real servers (gunicorn as the README runs it, and
runserver) and their real log output."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
import requests
from django.db import connection

from fleet.logs import HIDDEN, hide_keys, hide_query
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import ROOT, wait_until
from tests.support import COMMANDS, DATA, LEGACY_COMMANDS, LISTING_1, TELEMETRY
from vessels.models import Vessel


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ('"GET /spab/requestCommands.cgi?key=ssk_abc HTTP/1.1" 200 37',
         f'"GET /spab/requestCommands.cgi?key={HIDDEN} HTTP/1.1" 200 37'),
        ("/spab/data.cgi?v=2&key=legacy-secret&x=1", f"/spab/data.cgi?v=2&key={HIDDEN}&x=1"),
        # The names Django would decode to "key", and other key parameters.
        ("/spab/data.cgi?%6Bey=secret", f"/spab/data.cgi?%6Bey={HIDDEN}"),
        ("/api/v1/boat/commands/?API_KEY=secret", f"/api/v1/boat/commands/?API_KEY={HIDDEN}"),
        # A key-shaped string anywhere (a path, a header echoed in a message).
        ("Not Found: /spab/ssk_Ab-9_x", f"Not Found: /spab/ssk_{HIDDEN}"),
        ("GET /spab/data.cgi?x=1 HTTP/1.1", "GET /spab/data.cgi?x=1 HTTP/1.1"),
    ],
)  # fmt: skip
def test_hide_keys(text: str, shown: str) -> None:
    assert hide_keys(text) == shown


def test_hide_query_without_a_question_mark() -> None:
    assert hide_query("key=abc&since=5") == f"key={HIDDEN}&since=5"


def _database_url() -> str:
    """The test database, for a server in another process (committed rows only)."""
    s = connection.settings_dict
    if connection.vendor == "sqlite":
        return f"sqlite:///{s['NAME']}"
    return f"postgres://{s['USER']}@{s['HOST'] or '127.0.0.1'}:{s['PORT'] or 5432}/{s['NAME']}"


def _serve(args: list[str], port: int, log: Path) -> Iterator[str]:
    env = {**os.environ, "DATABASE_URL": _database_url(), "PYTHONUNBUFFERED": "1"}
    env.pop("NOTIFY_SOCKET", None)
    with open(log, "wb") as out:
        proc = subprocess.Popen([sys.executable, *args], cwd=ROOT, env=env, stdout=out,
                                stderr=subprocess.STDOUT)  # fmt: skip
        try:
            url = f"http://127.0.0.1:{port}"
            wait_until(lambda: _answers(url, proc, log), 60, f"{args[1]} on port {port}")
            yield url
        finally:
            proc.terminate()
            proc.wait(15)


def _answers(url: str, proc: subprocess.Popen, log: Path) -> bool:
    # A server that died (say its port was taken) fails at once and shows why, not after 60 s.
    if proc.poll() is not None:
        raise AssertionError(f"server exited {proc.returncode}:\n{log.read_text()[-2000:]}")
    try:
        requests.get(url + COMMANDS, timeout=10)
    except requests.ConnectionError:
        return False
    return True


def _use_keys_in_queries(url: str, key: str) -> None:
    """What a legacy boat does, and what a confused v1 client does (refused)."""
    assert requests.post(f"{url}{DATA}?key={key}", json=LISTING_1, timeout=10).status_code == 200
    assert requests.get(f"{url}{LEGACY_COMMANDS}?key={key}", timeout=10).status_code == 200
    assert requests.get(f"{url}{LEGACY_COMMANDS}?%6Bey={key}", timeout=10).status_code == 200
    wrong = requests.get(f"{url}{LEGACY_COMMANDS}?key={key}x", timeout=10)
    assert wrong.status_code == 401
    assert requests.get(f"{url}{COMMANDS}?key={key}", timeout=10).status_code == 401
    assert requests.post(f"{url}{TELEMETRY}?key={key}", json={}, timeout=10).status_code == 401


@pytest.mark.django_db(transaction=True)
def test_gunicorn_as_the_readme_runs_it_logs_no_key(
    vessel_a: Vessel, key_a: str, tmp_path: Path
) -> None:
    port, log = free_port(socket.SOCK_STREAM), tmp_path / "gunicorn.log"
    # The README's production command (gunicorn reads ./gunicorn.conf.py by itself).
    args = ["-m", "gunicorn", "fleet.wsgi", "-w", "1", "-b", f"127.0.0.1:{port}",
            "--access-logfile", "-", "--error-logfile", "-"]  # fmt: skip
    for url in _serve(args, port, log):
        _use_keys_in_queries(url, key_a)
    text = log.read_text()
    assert f"{LEGACY_COMMANDS}?key={HIDDEN}" in text  # the access log was on, masked
    assert f'"GET {COMMANDS}?key={HIDDEN} HTTP/1.1" 401' in text
    assert key_a not in text
    assert key_a.removeprefix("ssk_") not in text


@pytest.mark.django_db(transaction=True)
def test_runserver_logs_no_key(vessel_a: Vessel, key_a: str, tmp_path: Path) -> None:
    port, log = free_port(socket.SOCK_STREAM), tmp_path / "runserver.log"
    args = ["manage.py", "runserver", f"127.0.0.1:{port}", "--noreload", "--skip-checks"]
    for url in _serve(args, port, log):
        _use_keys_in_queries(url, key_a)
    text = log.read_text()
    # runserver logs refused requests (WARNING) with their request line; Django's request
    # logger says "Unauthorized: <path>".
    assert f"{COMMANDS}?key={HIDDEN}" in text
    assert "Unauthorized: " in text
    assert key_a not in text
    assert key_a.removeprefix("ssk_") not in text
