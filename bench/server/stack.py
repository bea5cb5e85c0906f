"""Process and database set-up: a fresh database, migrated and provisioned, served by gunicorn.

Everything started here is registered with :data:`CLEANUP`, which undoes it on normal exit,
error, Ctrl-C or SIGTERM.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from bench.server.client import http_request
from bench.server.constants import HELLO, HOST, SOAK_BOATS, single_post_slugs

ROOT = Path(__file__).resolve().parents[2]
PY = sys.executable
PG = {"host": HOST, "port": "5432", "user": "postgres"}


class Cleanup:
    """LIFO stack of undo actions, run once on normal exit, error, Ctrl-C or SIGTERM."""

    def __init__(self) -> None:
        self.actions: list[tuple[str, Callable[[], None]]] = []

    def push(self, name: str, action: Callable[[], None]) -> None:
        self.actions.append((name, action))

    def pop(self, action: Callable[[], None]) -> None:
        self.actions = [(n, a) for n, a in self.actions if a is not action]
        action()

    def run(self) -> None:
        while self.actions:
            name, action = self.actions.pop()
            try:
                action()
            except Exception as exc:  # noqa: BLE001 - keep cleaning up
                print(f"  cleanup {name}: {exc}", file=sys.stderr)


CLEANUP = Cleanup()


def ensure_wrk() -> str:
    found = shutil.which("wrk")
    if found:
        return found
    print("wrk not found: installing the Debian package (apt-get update; apt-get install -y wrk)")
    subprocess.run(["apt-get", "update"], check=True, timeout=600)
    subprocess.run(
        ["apt-get", "install", "-y", "wrk"],
        check=True,
        timeout=600,
        env={**os.environ, "DEBIAN_FRONTEND": "noninteractive"},
    )
    found = shutil.which("wrk")
    if not found:
        raise SystemExit("wrk is still missing after apt-get install")
    return found


def free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


@dataclass
class Stack:
    """One database plus one gunicorn serving bench.settings on it."""

    db: str
    env: dict[str, str]
    workdir: Path
    port: int = 0
    worker_class: str = "sync"
    threads: int = 1
    keys: dict[str, str] = field(default_factory=dict)
    server: subprocess.Popen[bytes] | None = None
    stop_server: Callable[[], None] | None = None

    @property
    def label(self) -> str:
        return "SQLite (WAL)" if self.db == "sqlite" else "PostgreSQL"

    def manage(self, *args: str, timeout: float = 600) -> str:
        done = subprocess.run(
            [PY, "manage.py", *args],
            cwd=ROOT,
            env=self.env,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        if done.returncode:
            raise SystemExit(f"manage.py {' '.join(args)} failed:\n{done.stdout}{done.stderr}")
        return done.stdout

    def helper(self, *args: str, timeout: float = 600) -> Any:
        """Run this module's Django-side helper (see ``django_helper``) on the stack's DB."""
        done = subprocess.run(
            [PY, "-m", "bench.server", "--_helper", *args],
            cwd=ROOT,
            env=self.env,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        if done.returncode:
            raise SystemExit(f"helper {args[0]} failed:\n{done.stdout}{done.stderr}")
        return json.loads(done.stdout.strip().splitlines()[-1])


def make_stack(db: str, worker_class: str, threads: int, profile: str | None) -> Stack:
    workdir = Path(tempfile.mkdtemp(prefix=f"shoreside-bench-{db}-"))
    CLEANUP.push(f"remove {workdir}", lambda: shutil.rmtree(workdir, ignore_errors=True))
    env = {
        k: v for k, v in os.environ.items() if k not in {"DATABASE_URL", "DJANGO_SETTINGS_MODULE"}
    }
    env.update(
        DJANGO_SETTINGS_MODULE="bench.settings",
        SHORESIDE_DATA_DIR=str(workdir / "data"),
        ALLOWED_HOSTS="127.0.0.1,localhost",
        DEBUG="0",
        PRODUCTION="0",
        LOG_LEVEL="WARNING",
        PYTHONDONTWRITEBYTECODE="1",
        # The operator's move_to targets are random and may go out before a boat's first fix:
        # the bench measures throughput, not the move limit.
        MOVE_TO_MAX_M="0",
    )
    if profile:
        Path(profile).mkdir(parents=True, exist_ok=True)
        env["BENCH_PROFILE_DIR"] = str(Path(profile).resolve() / db)
        Path(env["BENCH_PROFILE_DIR"]).mkdir(parents=True, exist_ok=True)
    if db == "postgres":
        name = f"shoreside_bench_{os.getpid()}"
        pg = ["-h", PG["host"], "-p", PG["port"], "-U", PG["user"]]
        quiet = {"check": True, "timeout": 60, "capture_output": True}
        subprocess.run(["dropdb", *pg, "--if-exists", "--force", name], **quiet)
        subprocess.run(["createdb", *pg, name], **quiet)
        CLEANUP.push(
            f"drop database {name}",
            lambda: subprocess.run(["dropdb", *pg, "--if-exists", "--force", name], **quiet),
        )
        env["DATABASE_URL"] = f"postgres://{PG['user']}@{PG['host']}:{PG['port']}/{name}"
    return Stack(db=db, env=env, workdir=workdir, worker_class=worker_class, threads=threads)


def start_server(stack: Stack) -> None:
    stack.port = free_port()
    log = open(stack.workdir / "gunicorn.log", "wb")  # noqa: SIM115 - closed by cleanup
    proc = subprocess.Popen(
        gunicorn_command(stack),
        cwd=ROOT,
        env=stack.env,
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    stack.server = proc

    def stop() -> None:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=10)
        log.close()

    CLEANUP.push(f"stop gunicorn {proc.pid}", stop)
    stack.stop_server = stop
    wait_until_answering(stack, proc)


def gunicorn_command(stack: Stack) -> list[str]:
    """gunicorn with 2 workers of the stack's class on 127.0.0.1:<port>, quiet logs."""
    cmd = [
        PY,
        "-m",
        "gunicorn",
        "fleet.wsgi:application",
        "--bind",
        f"{HOST}:{stack.port}",
        "--workers",
        "2",
        "--worker-class",
        stack.worker_class,
        "--log-level",
        "warning",
        "--timeout",
        "60",
    ]
    if stack.worker_class == "gthread":
        cmd += ["--threads", str(stack.threads)]
    return cmd


def wait_until_answering(stack: Stack, proc: subprocess.Popen[bytes]) -> None:
    """Return once the bare view answers 200; stop with its log if gunicorn exits or 60 s pass."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise SystemExit(
                "gunicorn exited:\n" + (stack.workdir / "gunicorn.log").read_text()[-3000:]
            )
        try:
            status, _, _ = http_request(stack.port, "GET", HELLO, timeout=2)
            if status == 200:
                return
        except OSError:
            pass
        time.sleep(0.2)
    raise SystemExit("gunicorn did not answer within 60 s")


def provision(stack: Stack, connections: int) -> None:
    slugs = [
        "ingest-batch",
        *single_post_slugs("ours", connections),
        "drf-batch",
        *single_post_slugs("drf", connections),
        "backlog",
        "drf-backlog",
        "poll",
        "drf-poll",
    ] + [f"boat-{i:03d}" for i in range(SOAK_BOATS)]
    stack.keys = stack.helper("provision", *slugs)
