"""``bash scripts/demo.sh`` run for real by the tests: its own ports, its own data folder and its
own session (so that every process it starts can be found, and none may outlive it)."""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import requests

from tests.edge_client.helpers import ROOT, wait_until

READY_S = 300  # migrate, collectstatic and seed on a fresh database, on a shared machine
STOP_S = 60
BANNER = re.compile(
    r"Open (http://127\.0\.0\.1:\d+/admin/) and log in as +user: (\S+) +password: (\S+)"
)


def free_port(kind: int) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def free_boat_ports() -> int:
    """A UDP port p with p + 10 free as well (the demo's two boats)."""
    for _ in range(50):
        port = free_port(socket.SOCK_DGRAM)
        if port + 10 < 65536:
            try:
                with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
                    s.bind(("127.0.0.1", port + 10))
            except OSError:
                continue
            return port
    raise RuntimeError("no pair of free UDP ports")


def demo_env(**extra: str) -> dict[str, str]:
    env = {**os.environ, "MAP_TILES_URL": "", "FLEET_MAP_POLL_S": "1", **extra}
    for name in ("DATABASE_URL", "NOTIFY_SOCKET"):  # the demo is SQLite in its own folder
        env.pop(name, None)
    return env


class Demo:
    """One run of the demo script; :meth:`ready` waits for its banner."""

    def __init__(self) -> None:
        # A short folder: the glider's modem socket lives in it (Unix socket paths are short).
        self.root = Path(tempfile.mkdtemp(prefix="demo-"))
        self.data = self.root / "site"
        self.port = free_port(socket.SOCK_STREAM)
        self.boat_port = free_boat_ports()
        self.env = demo_env(
            PORT=str(self.port), BOAT_PORT=str(self.boat_port), SHORESIDE_DATA_DIR=str(self.data)
        )
        self.output = self.root / "demo.out"
        self._log = open(self.output, "wb")  # noqa: SIM115 - closed by close()
        self.proc = subprocess.Popen(
            ["bash", "scripts/demo.sh"], cwd=ROOT, env=self.env, stdout=self._log,
            stderr=subprocess.STDOUT, start_new_session=True,
        )  # fmt: skip
        self.url = self.user = self.password = ""

    def text(self) -> str:
        return self.output.read_text(errors="replace")

    def ready(self) -> None:
        def banner() -> re.Match[str] | None:
            if self.proc.poll() is not None:
                raise AssertionError(f"demo.sh exited with {self.proc.returncode}:\n{self.text()}")
            return BANNER.search(self.text())

        found = wait_until(banner, READY_S, "the demo's banner")
        assert isinstance(found, re.Match)
        self.url, self.user, self.password = found.groups()
        self.site = self.url.removesuffix("/admin/")

    def processes(self) -> list[str]:
        """Every process of the demo's session (the script and all it started): 'pid args'."""
        out = subprocess.run(
            ["ps", "-o", "pid=,args=", "-s", str(self.proc.pid)],
            capture_output=True, text=True, check=False,
        ).stdout  # fmt: skip
        return [line.strip() for line in out.splitlines() if line.strip()]

    def manage(self, *args: str, data: Path | None = None) -> str:
        """``manage.py`` against the demo's database (or the glider's, ``data``)."""
        env = {**self.env, "SHORESIDE_DATA_DIR": str(data or self.data)}
        result = subprocess.run(
            [sys.executable, "manage.py", *args], cwd=ROOT, env=env, capture_output=True,
            text=True, timeout=120,
        )  # fmt: skip
        assert result.returncode == 0, result.stdout + result.stderr
        return result.stdout

    def api(self) -> requests.Session:
        """A session on the demo's operator API, with a token of the demo's operator."""
        token = self.manage("issue_token", self.user, "--name", "test").strip()
        session = requests.Session()
        session.headers["Authorization"] = f"Token {token}"
        return session

    def admin(self) -> requests.Session:
        """A session logged in to the demo's admin with the login its banner printed."""
        session = requests.Session()
        login = f"{self.site}/admin/login/"
        page = session.get(login, timeout=30).text
        csrf = re.search(r'name="csrfmiddlewaretoken" value="([^"]+)"', page)
        assert csrf, page
        answer = session.post(
            login,
            data={"username": self.user, "password": self.password, "next": "/admin/",
                  "csrfmiddlewaretoken": csrf.group(1)},
            headers={"Referer": login}, timeout=30,
        )  # fmt: skip
        assert answer.ok and "/admin/login/" not in answer.url, answer.text[:2000]
        return session

    def query(self, sql: str, *params: Any) -> list[tuple[Any, ...]]:
        """Read the demo's own database (read-only, beside the running site)."""
        db = sqlite3.connect(f"file:{self.data / 'shoreside.sqlite3'}?mode=ro", uri=True)
        try:
            return db.execute(sql, params).fetchall()
        finally:
            db.close()

    def signal(self, sig: int, *, group: bool = False) -> int:
        """Send ``sig`` to the script (or, as Ctrl-C in a terminal does, to its whole group);
        wait for it to end; its exit status."""
        if group:
            os.killpg(self.proc.pid, sig)
        else:
            self.proc.send_signal(sig)
        return self.proc.wait(STOP_S)

    def close(self) -> None:
        """Whatever happened: nothing of this run is left running, nor its folder."""
        if self.proc.poll() is None:
            try:
                self.signal(signal.SIGTERM)
            except subprocess.TimeoutExpired:
                pass
        leftover = [int(line.split()[0]) for line in self.processes()]
        for pid in leftover:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        if self.proc.poll() is None:
            self.proc.wait(10)
        self._log.close()
        shutil.rmtree(self.root, ignore_errors=True)


def gone_within(demo: Demo, seconds: float) -> list[str]:
    """The demo's processes still there after ``seconds`` (an empty list: all gone)."""
    deadline = time.monotonic() + seconds
    while (left := demo.processes()) and time.monotonic() < deadline:
        time.sleep(0.2)
    return left
