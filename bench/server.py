"""Issue-2 speed benchmark: the real stack (gunicorn + Django) under wrk, beside baselines.

    python -m bench.server                   # full run, SQLite (WAL) then PostgreSQL
    python -m bench.server --quick --db sqlite
    python -m bench.server --soak-seconds 60 --worker-class sync
    python -m bench.server --profile /tmp/prof --db sqlite   # cProfile every worker request

For each database: a fresh data dir (SQLite) or a throwaway database (PostgreSQL), migrated;
gunicorn with 2 workers on 127.0.0.1 serving `bench.settings` (production settings + the
baseline routes of bench.baseline); load from wrk (Lua scripts in bench/lua) and from a small
asyncio client for the 200-boat mixed run. Every figure is printed beside the baselines measured
in the same run and the issue's target. Servers, data dir and database are removed on exit,
also on Ctrl-C. Only 127.0.0.1 is ever contacted.
"""

from __future__ import annotations

import argparse
import asyncio
import datetime as dt
import http.client
import json
import os
import random
import resource
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

ROOT = Path(__file__).resolve().parent.parent
LUA = Path(__file__).resolve().parent / "lua"
PY = sys.executable
HOST = "127.0.0.1"
PG = {"host": HOST, "port": "5432", "user": "postgres"}

# The targets of issue 2 ("Speed").
TARGET_INGEST_FPS = 25_000
TARGET_BACKLOG_S = 4.0
TARGET_SINGLE_PPS = 1_000
TARGET_304_BYTES = 200
TARGET_POLL_MEDIAN_MS = 2.0
TARGET_POLLS_PS = 1_000
TARGET_SOAK_P99_MS = 100.0

BACKLOG_FIXES = 86_400
BATCH = 500
SOAK_BOATS = 200
POLL_EVERY_S = 5.0
POST_EVERY_S = 10.0
FIXES_PER_POST = 10  # 10 s of 1 Hz fixes per post
OPERATOR_EVERY_S = 2.0

TELEMETRY = "/api/v1/boat/telemetry/"
COMMANDS = "/api/v1/boat/commands/"
HELLO = "/bench/hello/"
DRF_TELEMETRY = "/bench/drf/telemetry/"
DRF_COMMANDS = "/bench/drf/commands/"


# --------------------------------------------------------------------------- cleanup


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


def _on_sigterm(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


# --------------------------------------------------------------------------- tools


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
    proc = subprocess.Popen(
        cmd, cwd=ROOT, env=stack.env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
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


def http_request(
    port: int,
    method: str,
    path: str,
    body: bytes | None = None,
    headers: dict[str, str] | None = None,
    timeout: float = 30,
) -> tuple[int, dict[str, str], bytes]:
    conn = http.client.HTTPConnection(HOST, port, timeout=timeout)
    try:
        conn.request(method, path, body=body, headers=headers or {})
        response = conn.getresponse()
        return response.status, dict(response.getheaders()), response.read()
    finally:
        conn.close()


def raw_response_head(port: int, request: bytes) -> bytes:
    """Send ``request`` on a raw socket; return the status line and headers, byte for byte."""
    with socket.create_connection((HOST, port), timeout=10) as s:
        s.sendall(request)
        data = b""
        deadline = time.monotonic() + 10
        while b"\r\n\r\n" not in data and time.monotonic() < deadline:
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    head, sep, _ = data.partition(b"\r\n\r\n")
    return head + sep


# --------------------------------------------------------------------------- wrk


@dataclass
class WrkResult:
    requests: int
    seconds: float
    ok: int
    bad: int
    errors: int
    first_bad: str
    p50_ms: float
    p90_ms: float
    p99_ms: float
    max_ms: float
    cpu_ms: float  # gunicorn's CPU time (all workers) per request answered
    client_cpu_ms: float  # wrk's CPU time per request (it shares the 2 cores)

    @property
    def rps(self) -> float:
        return self.ok / self.seconds if self.seconds else 0.0


def tree_cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of ``pid`` and its descendants so far (Linux /proc)."""
    total = 0.0
    todo = [pid]
    tick = os.sysconf("SC_CLK_TCK")
    while todo:
        p = todo.pop()
        try:
            stat = Path(f"/proc/{p}/stat").read_text()
            fields = stat[stat.rindex(")") + 2 :].split()
            total += (int(fields[11]) + int(fields[12])) / tick
            for task in Path(f"/proc/{p}/task").iterdir():
                todo += [int(c) for c in (task / "children").read_text().split()]
        except (OSError, ValueError):
            continue
    return total


def wrk(
    stack: Stack,
    path: str,
    script: str,
    args: list[str],
    *,
    seconds: float,
    connections: int,
    threads: int = 1,
) -> WrkResult:
    cmd = [
        "wrk",
        f"-t{threads}",
        f"-c{connections}",
        f"-d{max(1, round(seconds))}s",
        "--timeout",
        "10s",
        "-s",
        str(LUA / script),
        f"http://{HOST}:{stack.port}{path}",
        "--",
        *args,
    ]
    pid = stack.server.pid if stack.server else 0
    cpu_before = tree_cpu_seconds(pid)
    client_before = resource.getrusage(resource.RUSAGE_CHILDREN)
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=seconds + 60)
    client_after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = tree_cpu_seconds(pid) - cpu_before
    client = (client_after.ru_utime + client_after.ru_stime) - (
        client_before.ru_utime + client_before.ru_stime
    )
    line = next((ln for ln in done.stdout.splitlines() if ln.startswith("BENCH_JSON ")), None)
    if done.returncode or line is None:
        raise SystemExit(f"wrk failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    data = json.loads(line.removeprefix("BENCH_JSON "))
    errors = sum(data[k] for k in ("connect_errors", "read_errors", "write_errors", "timeouts"))
    return WrkResult(
        requests=data["requests"],
        seconds=data["duration_us"] / 1e6,
        ok=data["ok"],
        bad=data["bad"],
        errors=errors,
        first_bad=data["first_bad"],
        p50_ms=data["lat_p50_us"] / 1000,
        p90_ms=data["lat_p90_us"] / 1000,
        p99_ms=data["lat_p99_us"] / 1000,
        max_ms=data["lat_max_us"] / 1000,
        cpu_ms=1000 * cpu / max(1, data["requests"]),
        client_cpu_ms=1000 * client / max(1, data["requests"]),
    )


class Clock:
    """Hands out disjoint ranges of past fix times, so no two phases ever share a timestamp."""

    def __init__(self) -> None:
        self.next = 1_546_300_800  # 2019-01-01: plausible, and ~2.5e8 s before today

    def take(self, seconds: int) -> int:
        first = self.next
        self.next += seconds + 3600
        return first


# --------------------------------------------------------------------------- phases


@dataclass
class Figures:
    rows: list[tuple[str, str, str, str, str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    stored: dict[str, int] = field(default_factory=dict)

    def row(
        self,
        name: str,
        value: str,
        drf: str = "",
        bare: str = "",
        target: str = "",
        verdict: bool | None = None,
    ) -> None:
        mark = "" if verdict is None else ("PASS" if verdict else "MISS")
        self.rows.append((name, value, drf, bare, target, mark))
        print(f"    {name}: {value}  | DRF {drf or '-'} | bare {bare or '-'} | {target} {mark}")


def fmt(n: float, digits: int = 0) -> str:
    return f"{n:,.{digits}f}"


def check_wrk(name: str, r: WrkResult, figures: Figures) -> None:
    if r.bad or r.errors:
        figures.notes.append(
            f"{name}: {r.bad} unexpected answers, {r.errors} socket errors/timeouts of "
            f"{r.requests} (first: {r.first_bad[:120]})"
        )


def iso_times(first: int, count: int) -> list[str]:
    base = dt.datetime.fromtimestamp(first, dt.UTC)
    return [(base + dt.timedelta(seconds=i)).isoformat() for i in range(count)]


def fix_body(times: list[str]) -> bytes:
    fixes = [
        {
            "time": t,
            "lat": -32.05 + (i % 1000) * 1e-5,
            "lon": 115.74 + (i % 777) * 1e-5,
            "heading_deg": (i * 7) % 360,
            "speed_mps": 1.5,
            "battery_v": 12.6,
            "readings": {"water_temp_c": 18.2, "salinity_psu": 35.1},
        }
        for i, t in enumerate(times)
    ]
    return json.dumps({"fixes": fixes}).encode()


def backlog_upload(port: int, path: str, key: str, first: int) -> tuple[float, int]:
    """One boat uploads a day of 1 Hz fixes in batches of 500, sequentially; (seconds, accepted).

    Bodies are encoded before the clock starts; one keep-alive connection where the server
    allows it (http.client reconnects when the server closes)."""
    times = iso_times(first, BACKLOG_FIXES)
    bodies = [fix_body(times[i : i + BATCH]) for i in range(0, BACKLOG_FIXES, BATCH)]
    headers = {"Authorization": f"Api-Key {key}", "Content-Type": "application/json"}
    conn = http.client.HTTPConnection(HOST, port, timeout=60)
    accepted = 0
    start = time.perf_counter()
    try:
        for body in bodies:
            conn.request("POST", path, body=body, headers=headers)
            response = conn.getresponse()
            payload = response.read()
            if response.status == 200:
                accepted += json.loads(payload).get("accepted", 0)
            if response.will_close:
                conn.close()
    finally:
        conn.close()
    return time.perf_counter() - start, accepted


def run_ingest(stack: Stack, opts: argparse.Namespace, clock: Clock, figures: Figures) -> None:
    port, k = stack.port, stack.keys
    dur, warm = opts.phase_seconds, opts.warmup_seconds
    conns = opts.connections
    results: dict[str, WrkResult] = {}
    warm_ok: dict[str, int] = {}
    for name, path, slug, batch in (
        ("batch", TELEMETRY, "ingest-batch", BATCH),
        ("drf-batch", DRF_TELEMETRY, "drf-batch", BATCH),
        ("single", TELEMETRY, "ingest-single", 1),
        ("drf-single", DRF_TELEMETRY, "drf-single", 1),
    ):
        warmup = wrk(
            stack,
            path,
            "ingest.lua",
            [str(batch), str(clock.take(2 * 10**6)), k[slug]],
            seconds=warm,
            connections=conns,
        )
        warm_ok[slug] = warmup.ok * batch
        r = wrk(
            stack,
            path,
            "ingest.lua",
            [str(batch), str(clock.take(2 * 10**6)), k[slug]],
            seconds=dur,
            connections=conns,
        )
        results[name] = r
        check_wrk(f"ingest {name}", r, figures)
        print(
            f"  {name:<11} {r.rps * batch:>10,.0f} fixes/s  {r.rps:>8,.1f} req/s  "
            f"p50 {r.p50_ms:.1f} ms  p99 {r.p99_ms:.1f} ms  CPU/req server {r.cpu_ms:.2f} ms, "
            f"wrk {r.client_cpu_ms:.2f} ms  bad {r.bad} err {r.errors}"
        )
    hello = wrk(stack, HELLO, "get.lua", ["200"], seconds=dur, connections=conns)
    results["hello"] = hello
    check_wrk("bare view", hello, figures)
    print(
        f"  bare view   {hello.rps:>10,.0f} req/s  p50 {hello.p50_ms:.2f} ms  "
        f"server CPU {hello.cpu_ms:.2f} ms/req"
    )

    seq, seq_accepted = backlog_upload(port, TELEMETRY, k["backlog"], clock.take(BACKLOG_FIXES))
    drf_seq, drf_accepted = backlog_upload(
        port, DRF_TELEMETRY, k["drf-backlog"], clock.take(BACKLOG_FIXES)
    )
    print(f"  backlog     {seq:.2f} s ({seq_accepted} accepted); DRF {drf_seq:.2f} s")
    for name, accepted in (("backlog", seq_accepted), ("DRF backlog", drf_accepted)):
        if accepted != BACKLOG_FIXES:
            figures.notes.append(f"{name}: accepted {accepted} of {BACKLOG_FIXES} fixes")

    b, db_, s, ds = results["batch"], results["drf-batch"], results["single"], results["drf-single"]
    fps = b.rps * BATCH
    figures.row(
        f"ingest, batches of {BATCH} (fixes/s, wrk -c{conns})",
        fmt(fps),
        fmt(db_.rps * BATCH),
        "",
        f">= {TARGET_INGEST_FPS:,}",
        fps >= TARGET_INGEST_FPS,
    )
    figures.row(
        "  p50 / p99 per batch (ms)",
        f"{b.p50_ms:.0f} / {b.p99_ms:.0f}",
        f"{db_.p50_ms:.0f} / {db_.p99_ms:.0f}",
    )
    figures.row(
        "  server CPU per fix, batches (us)",
        fmt(1000 * b.cpu_ms / BATCH, 1),
        fmt(1000 * db_.cpu_ms / BATCH, 1),
    )
    figures.row(
        "86,400 fixes at that rate (s)",
        fmt(BACKLOG_FIXES / fps, 2) if fps else "inf",
        fmt(BACKLOG_FIXES / (db_.rps * BATCH), 2) if db_.rps else "inf",
        "",
        f"<= {TARGET_BACKLOG_S:g}",
        fps > 0 and BACKLOG_FIXES / fps <= TARGET_BACKLOG_S,
    )
    figures.row(
        "86,400 fixes, one boat, sequential (s)",
        fmt(seq, 2),
        fmt(drf_seq, 2),
        "",
        f"<= {TARGET_BACKLOG_S:g}",
        seq <= TARGET_BACKLOG_S,
    )
    figures.row(
        f"single-fix posts/s (wrk -c{conns})",
        fmt(s.rps),
        fmt(ds.rps),
        f"{fmt(hello.rps)} GET/s",
        f">= {TARGET_SINGLE_PPS:,}",
        s.rps >= TARGET_SINGLE_PPS,
    )
    figures.row(
        "  p50 / p99 single post (ms)",
        f"{s.p50_ms:.1f} / {s.p99_ms:.1f}",
        f"{ds.p50_ms:.1f} / {ds.p99_ms:.1f}",
        f"{hello.p50_ms:.1f} / {hello.p99_ms:.1f}",
    )
    figures.row(
        "  server CPU per single post (ms)",
        fmt(s.cpu_ms, 2),
        fmt(ds.cpu_ms, 2),
        f"{fmt(hello.cpu_ms, 2)} (GET)",
    )
    figures.stored.update(
        {
            "ingest-batch": b.ok * BATCH + warm_ok["ingest-batch"],
            "ingest-single": s.ok + warm_ok["ingest-single"],
            "drf-batch": db_.ok * BATCH + warm_ok["drf-batch"],
            "drf-single": ds.ok + warm_ok["drf-single"],
            "backlog": seq_accepted,
            "drf-backlog": drf_accepted,
        }
    )


def get_request(path: str, key: str = "", etag: str = "") -> bytes:
    lines = [f"GET {path} HTTP/1.1", f"Host: {HOST}"]
    if key:
        lines.append(f"Authorization: Api-Key {key}")
    if etag:
        lines.append(f"If-None-Match: {etag}")
    return ("\r\n".join(lines) + "\r\n\r\n").encode()


def run_poll(stack: Stack, opts: argparse.Namespace, figures: Figures) -> None:
    port, key, drf_key = stack.port, stack.keys["poll"], stack.keys["drf-poll"]
    auth = {"Authorization": f"Api-Key {key}"}
    status, headers, _ = http_request(port, "GET", COMMANDS, headers=auth)
    etag = headers.get("ETag", "")
    status_drf, headers_drf, _ = http_request(
        port, "GET", DRF_COMMANDS, headers={"Authorization": f"Api-Key {drf_key}"}
    )
    drf_etag = headers_drf.get("ETag", "")
    if status != 200 or not etag or status_drf != 200 or not drf_etag:
        raise SystemExit(f"poll set-up failed: {status} {etag!r}; DRF {status_drf} {drf_etag!r}")
    head = raw_response_head(port, get_request(COMMANDS, key, etag))
    head_drf = raw_response_head(port, get_request(DRF_COMMANDS, drf_key, drf_etag))
    head_hello = raw_response_head(port, get_request(HELLO))
    if not head.startswith(b"HTTP/1.1 304"):
        figures.notes.append(f"no-news poll did not answer 304: {head[:60]!r}")
    print("  no-news poll, whole response head:")
    for line in head.decode("latin-1").splitlines():
        print(f"      {line}")
    print("  DRF baseline 304 head:")
    for line in head_drf.decode("latin-1").splitlines():
        print(f"      {line}")

    dur, warm = opts.phase_seconds, opts.warmup_seconds
    wrk(stack, COMMANDS, "get.lua", ["304", key, etag], seconds=warm, connections=1)
    one = wrk(stack, COMMANDS, "get.lua", ["304", key, etag], seconds=dur, connections=1)
    one_drf = wrk(
        stack, DRF_COMMANDS, "get.lua", ["304", drf_key, drf_etag], seconds=dur, connections=1
    )
    one_hello = wrk(stack, HELLO, "get.lua", ["200"], seconds=dur, connections=1)
    conns = opts.poll_connections
    many = wrk(stack, COMMANDS, "get.lua", ["304", key, etag], seconds=dur, connections=conns)
    many_drf = wrk(
        stack, DRF_COMMANDS, "get.lua", ["304", drf_key, drf_etag], seconds=dur, connections=conns
    )
    many_hello = wrk(stack, HELLO, "get.lua", ["200"], seconds=dur, connections=conns)
    for name, r in (
        ("poll c1", one),
        ("DRF poll c1", one_drf),
        ("bare c1", one_hello),
        (f"poll c{conns}", many),
        (f"DRF poll c{conns}", many_drf),
        (f"bare c{conns}", many_hello),
    ):
        check_wrk(name, r, figures)
        print(
            f"  {name:<12} {r.rps:>8,.0f} req/s  p50 {r.p50_ms:.2f} ms  p99 {r.p99_ms:.2f} ms  "
            f"server CPU {r.cpu_ms:.2f} ms/req"
        )

    figures.row(
        "no-news poll: 304 status line + headers (bytes)",
        str(len(head)),
        str(len(head_drf)),
        f"{len(head_hello)} (200)",
        f"<= {TARGET_304_BYTES}",
        len(head) <= TARGET_304_BYTES and head.startswith(b"HTTP/1.1 304"),
    )
    figures.row(
        "no-news poll, 1 conn: median (ms)",
        f"{one.p50_ms:.2f}",
        f"{one_drf.p50_ms:.2f}",
        f"{one_hello.p50_ms:.2f}",
        f"<= {TARGET_POLL_MEDIAN_MS:g}",
        one.p50_ms <= TARGET_POLL_MEDIAN_MS,
    )
    figures.row(
        "no-news poll, 1 conn: p99 (ms)",
        f"{one.p99_ms:.2f}",
        f"{one_drf.p99_ms:.2f}",
        f"{one_hello.p99_ms:.2f}",
    )
    figures.row(
        f"no-news polls/s (wrk -c{conns})",
        fmt(many.rps),
        fmt(many_drf.rps),
        f"{fmt(many_hello.rps)} GET/s",
        f">= {TARGET_POLLS_PS:,}",
        many.rps >= TARGET_POLLS_PS,
    )
    figures.row(
        "  server CPU per poll (ms)",
        fmt(many.cpu_ms, 2),
        fmt(many_drf.cpu_ms, 2),
        f"{fmt(many_hello.cpu_ms, 2)} (200)",
    )


# --------------------------------------------------------------------------- mixed run


@dataclass
class Sample:
    kind: str
    ms: float
    ok: bool
    detail: str = ""
    at: float = field(default_factory=time.monotonic)  # when the request started


async def aio_request(
    port: int, method: str, path: str, headers: dict[str, str], body: bytes = b""
) -> tuple[int, dict[str, str], bytes]:
    """One HTTP/1.1 request on its own connection (a boat on a cellular link)."""
    reader, writer = await asyncio.open_connection(HOST, port)
    try:
        lines = [f"{method} {path} HTTP/1.1", f"Host: {HOST}", "Connection: close"]
        lines += [f"{k}: {v}" for k, v in headers.items()]
        if body:
            lines += ["Content-Type: application/json", f"Content-Length: {len(body)}"]
        writer.write(("\r\n".join(lines) + "\r\n\r\n").encode() + body)
        await writer.drain()
        head = await reader.readuntil(b"\r\n\r\n")
        status_line, *header_lines = head.decode("latin-1").split("\r\n")
        status = int(status_line.split()[1])
        got = {}
        for line in header_lines:
            if ":" in line:
                name, _, value = line.partition(":")
                got[name.strip().lower()] = value.strip()
        length = int(got.get("content-length", "0") or 0)
        payload = await reader.readexactly(length) if length else b""
        return status, got, payload
    finally:
        writer.close()


async def timed(samples: list[Sample], kind: str, coro: Any, check: Callable[..., str]) -> Any:
    start = time.perf_counter()
    try:
        status, headers, payload = await asyncio.wait_for(coro, timeout=10)
    except (TimeoutError, OSError, asyncio.IncompleteReadError, ValueError) as exc:
        failed = Sample(kind, (time.perf_counter() - start) * 1000, False, repr(exc))
        failed.at -= failed.ms / 1000
        samples.append(failed)
        return None
    ms = (time.perf_counter() - start) * 1000
    problem = check(status, payload)
    sample = Sample(kind, ms, not problem, problem)
    sample.at -= ms / 1000
    samples.append(sample)
    return status, headers, payload


async def boat(
    port: int, key: str, end: float, samples: list[Sample], rng: random.Random, first: int
) -> None:
    auth = {"Authorization": f"Api-Key {key}"}
    now = time.monotonic()
    next_poll = now + rng.uniform(0, POLL_EVERY_S)
    next_post = now + rng.uniform(0, POST_EVERY_S)
    etag = ""
    posted = 0

    def poll_ok(status: int, payload: bytes) -> str:
        return "" if status in (200, 304) else f"poll {status} {payload[:100]!r}"

    def post_ok(status: int, payload: bytes) -> str:
        if status != 200:
            return f"post {status} {payload[:100]!r}"
        if json.loads(payload).get("accepted") != FIXES_PER_POST:
            return f"post accepted {payload[:100]!r}"
        return ""

    def ack_ok(status: int, payload: bytes) -> str:
        return "" if status == 200 else f"ack {status} {payload[:100]!r}"

    while True:
        wake = min(next_poll, next_post)
        if wake >= end:
            return
        await asyncio.sleep(max(0.0, wake - time.monotonic()))
        if next_post <= next_poll:
            next_post += POST_EVERY_S
            times = iso_times(first + posted * FIXES_PER_POST, FIXES_PER_POST)
            posted += 1
            await timed(
                samples,
                "post",
                aio_request(port, "POST", TELEMETRY, auth, fix_body(times)),
                post_ok,
            )
            continue
        next_poll += POLL_EVERY_S
        headers = {**auth, "If-None-Match": etag} if etag else auth
        got = await timed(samples, "poll", aio_request(port, "GET", COMMANDS, headers), poll_ok)
        if got is None:
            continue
        status, resp_headers, payload = got
        if status == 304:
            samples.append(Sample("poll-304", 0, True))
            continue
        etag = resp_headers.get("etag", "")
        for command in json.loads(payload).get("commands", []):
            ack = json.dumps({"status": "done", "detail": "bench"}).encode()
            await timed(
                samples,
                "ack",
                aio_request(port, "POST", f"{COMMANDS}{command['uid']}/ack/", auth, ack),
                ack_ok,
            )


async def operator(
    port: int, token: str, slugs: list[str], end: float, samples: list[Sample], rng: random.Random
) -> None:
    """Queues a move_to for a random boat every OPERATOR_EVERY_S (the poll answers change)."""
    headers = {"Authorization": f"Token {token}"}

    def created(status: int, payload: bytes) -> str:
        return "" if status == 201 else f"enqueue {status} {payload[:100]!r}"

    while time.monotonic() + OPERATOR_EVERY_S < end:
        await asyncio.sleep(OPERATOR_EVERY_S)
        body = json.dumps(
            {"kind": "move_to", "params": {"lat": -32.0 - rng.random() / 10, "lon": 115.7}}
        ).encode()
        slug = rng.choice(slugs)
        await timed(
            samples,
            "enqueue",
            aio_request(port, "POST", f"/api/v1/vessels/{slug}/commands/", headers, body),
            created,
        )


async def soak_async(stack: Stack, seconds: float, first: int) -> list[Sample]:
    samples: list[Sample] = []
    rng = random.Random(2)
    end = time.monotonic() + seconds
    slugs = [f"boat-{i:03d}" for i in range(SOAK_BOATS)]
    tasks = [
        boat(stack.port, stack.keys[slug], end, samples, random.Random(i), first + i * 10**4)
        for i, slug in enumerate(slugs)
    ]
    tasks.append(operator(stack.port, stack.keys["@operator-token"], slugs, end, samples, rng))
    await asyncio.wait_for(asyncio.gather(*tasks), timeout=seconds + 120)
    return samples


def percentile(values: list[float], q: float) -> float:
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def run_soak(stack: Stack, opts: argparse.Namespace, clock: Clock, figures: Figures) -> None:
    seconds = opts.soak_seconds
    print(
        f"  mixed run: {SOAK_BOATS} boats, poll every {POLL_EVERY_S:g} s, post "
        f"{FIXES_PER_POST} fixes every {POST_EVERY_S:g} s, operator queues a move_to every "
        f"{OPERATOR_EVERY_S:g} s, for {seconds:g} s ...",
        flush=True,
    )
    began = time.monotonic()
    samples = asyncio.run(soak_async(stack, seconds, clock.take(2 * 10**6)))
    real = [s for s in samples if s.kind != "poll-304"]
    errors = [s for s in real if not s.ok]
    by_kind: dict[str, list[float]] = {}
    for s in real:
        by_kind.setdefault(s.kind, []).append(s.ms)
    all_ms = [s.ms for s in real]
    p99 = percentile(all_ms, 99)
    n304 = sum(1 for s in samples if s.kind == "poll-304")
    for kind, values in sorted(by_kind.items()):
        print(
            f"    {kind:<8} n={len(values):>6}  p50 {percentile(values, 50):6.1f} ms  "
            f"p99 {percentile(values, 99):6.1f} ms  max {max(values):6.1f} ms"
        )
    print(f"    polls answered 304: {n304}; errors: {len(errors)}")
    for s in errors[:5]:
        print(f"      error: {s.kind} {s.detail[:160]}")
    rate = len(real) / seconds if seconds else 0
    figures.row(
        f"mixed {SOAK_BOATS} boats, {seconds:g} s: requests (req/s)",
        f"{len(real):,} ({rate:.0f}/s)",
    )
    figures.row(
        "mixed run: errors",
        str(len(errors)),
        "",
        "",
        "0",
        not errors and len(real) > 0,
    )
    figures.row(
        "mixed run: p50 / p99 / max, per request incl. connect (ms)",
        f"{percentile(all_ms, 50):.1f} / {p99:.1f} / {max(all_ms, default=0):.1f}",
        "",
        "",
        f"p99 < {TARGET_SOAK_P99_MS:g}",
        p99 < TARGET_SOAK_P99_MS,
    )
    steady = [s.ms for s in real if s.at >= began + 2 * POLL_EVERY_S]
    figures.row(
        f"  same, after the first {2 * POLL_EVERY_S:g} s (ms)",
        f"{percentile(steady, 50):.1f} / {percentile(steady, 99):.1f} / "
        f"{max(steady, default=0):.1f}",
    )
    figures.notes.append(
        f"mixed run: each boat starts with one queued `hold`, so in the first {POLL_EVERY_S:g} s "
        f"all {SOAK_BOATS} boats claim a command and ack it at once (a fleet-wide order); "
        "then the operator's commands trickle in. p99 per kind: "
        + ", ".join(f"{k} {percentile(v, 99):.0f} ms" for k, v in sorted(by_kind.items()))
    )
    if errors:
        figures.notes.append(f"mixed run errors, first: {errors[0].kind} {errors[0].detail}")
    figures.stored["soak-posts"] = sum(1 for s in real if s.kind == "post" and s.ok)


# --------------------------------------------------------------------------- orchestration


def provision(stack: Stack) -> None:
    slugs = [
        "ingest-batch",
        "ingest-single",
        "drf-batch",
        "drf-single",
        "backlog",
        "drf-backlog",
        "poll",
        "drf-poll",
    ] + [f"boat-{i:03d}" for i in range(SOAK_BOATS)]
    stack.keys = stack.helper("provision", *slugs)


def count_stored(stack: Stack, figures: Figures) -> None:
    counts = stack.helper("count")
    soak_fixes = sum(v for s, v in counts.items() if s.startswith("boat-"))
    expected = dict(figures.stored)
    soak_posts = expected.pop("soak-posts", 0)
    lines = []
    for slug, answered in expected.items():
        lines.append(f"{slug} {counts.get(slug, 0)}/{answered}")
        if counts.get(slug, 0) < answered:
            figures.notes.append(f"LOST FIXES: {slug} stored {counts.get(slug)} < {answered}")
    lines.append(f"mixed-run boats {soak_fixes}/{soak_posts * FIXES_PER_POST}")
    if soak_fixes < soak_posts * FIXES_PER_POST:
        figures.notes.append("LOST FIXES in the mixed run")
    figures.notes.append(
        "fixes stored / answered as accepted, warm-ups included (stored may exceed: wrk "
        "drops the answers still in flight when it stops): " + ", ".join(lines)
    )


def print_table(stack: Stack, figures: Figures, elapsed: float) -> None:
    server = f"gunicorn 2 x {stack.worker_class}"
    if stack.worker_class == "gthread":
        server += f" ({stack.threads} threads)"
    title = f"{stack.label}, {server}, wrk -t1 on the same 2 cores"
    headers = ("figure", "shoreside", "DRF baseline", "bare Django", "target", "")
    widths = [max(len(str(r[i])) for r in [headers, *figures.rows]) for i in range(6)]
    print()
    print("=" * len(title))
    print(title)
    print("=" * len(title))
    line = "  ".join(str(h).ljust(w) for h, w in zip(headers, widths, strict=True))
    print(line)
    print("-" * len(line))
    for row in figures.rows:
        cells = [row[0].ljust(widths[0])] + [
            str(c).rjust(w) for c, w in zip(row[1:5], widths[1:5], strict=True)
        ]
        print("  ".join(cells) + "  " + row[5])
    for note in figures.notes:
        print(f"  * {note}")
    print(
        f"  ({elapsed:.0f} s for this database; load average now {os.getloadavg()[0]:.1f}: "
        "other processes on these 2 cores lower every req/s figure; server CPU per request "
        "is the steadier measure)"
    )


def summarize_profile(profile_dir: Path) -> None:
    import pstats

    files = sorted(str(p) for p in profile_dir.glob("worker-*.prof"))
    if not files:
        print(f"  no profile files in {profile_dir}")
        return
    stats = pstats.Stats(*files)
    stats.strip_dirs()
    print(f"\n--- cProfile of all requests, {profile_dir} (top by own time) ---")
    stats.sort_stats("tottime").print_stats(30)
    print("--- same, by cumulative time ---")
    stats.sort_stats("cumulative").print_stats(40)


def bench_db(db: str, opts: argparse.Namespace) -> None:
    started = time.monotonic()
    stack = make_stack(db, opts.worker_class, opts.threads, opts.profile)
    print(f"\n### {stack.label}: migrating a fresh database ...", flush=True)
    stack.manage("migrate", "--noinput")
    provision(stack)
    start_server(stack)
    print(f"### gunicorn 2 x {stack.worker_class} on {HOST}:{stack.port}", flush=True)
    clock = Clock()
    figures = Figures()
    print("- ingest", flush=True)
    run_ingest(stack, opts, clock, figures)
    print("- poll", flush=True)
    run_poll(stack, opts, figures)
    print("- mixed run", flush=True)
    run_soak(stack, opts, clock, figures)
    if stack.stop_server:
        CLEANUP.pop(stack.stop_server)
    count_stored(stack, figures)
    print_table(stack, figures, time.monotonic() - started)
    if opts.profile:
        summarize_profile(Path(stack.env["BENCH_PROFILE_DIR"]))
    CLEANUP.run()


# --------------------------------------------------------------------------- Django side


def django_helper(args: list[str]) -> None:
    """Runs inside a subprocess with the stack's environment: provision vessels, count fixes."""
    import django

    django.setup()
    from django.contrib.auth import get_user_model
    from django.db.models import Count

    from commands.services import command_enqueue
    from operators.services import operator_token_issue
    from vessels.models import Vessel
    from vessels.services import vessel_create, vessel_key_issue

    command, *rest = args
    if command == "provision":
        keys: dict[str, str] = {}
        for slug in rest:
            vessel = vessel_create(slug=slug, name=f"Bench {slug}", kind="mavlink")
            _key, keys[slug] = vessel_key_issue(vessel=vessel, label="bench")
            if slug.startswith("boat-"):
                command_enqueue(vessel=vessel, kind="hold", params={}, created_by="bench")
        user = get_user_model().objects.create_superuser("bench", "bench@example.invalid", None)
        keys["@operator-token"] = operator_token_issue(user=user, name="bench", expires_in=None)[1]
        print(json.dumps(keys))
    elif command == "count":
        rows = Vessel.objects.annotate(n=Count("fixes")).values_list("slug", "n")
        print(json.dumps(dict(rows)))
    else:
        raise SystemExit(f"unknown helper {command}")


# --------------------------------------------------------------------------- main


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m bench.server", description=__doc__.split("\n")[0])
    p.add_argument("--db", choices=["sqlite", "postgres", "both"], default="both")
    p.add_argument("--quick", action="store_true", help="short phases and a 20 s mixed run")
    p.add_argument("--soak-seconds", type=float, help="mixed-run length (default 300, quick 20)")
    p.add_argument("--phase-seconds", type=float, help="each wrk phase (default 20, quick 3)")
    p.add_argument("--worker-class", choices=["sync", "gthread"], default="sync")
    p.add_argument("--threads", type=int, default=4, help="threads per gthread worker")
    p.add_argument("--connections", type=int, default=4, help="wrk connections for ingest")
    p.add_argument("--poll-connections", type=int, default=16, help="wrk connections, polls/s")
    p.add_argument("--profile", metavar="DIR", help="cProfile every request into DIR/<db>/")
    p.add_argument("--_helper", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    opts = p.parse_args(argv)
    if opts.phase_seconds is None:
        opts.phase_seconds = 3.0 if opts.quick else 20.0
    opts.warmup_seconds = 1.0 if opts.quick else 3.0
    if opts.soak_seconds is None:
        opts.soak_seconds = 20.0 if opts.quick else 300.0
    for name in ("phase_seconds", "soak_seconds"):
        if not 1 <= getattr(opts, name) <= 3600:
            p.error(f"--{name.replace('_', '-')} must be between 1 and 3600")
    return opts


def main(argv: list[str] | None = None) -> None:
    opts = parse_args(sys.argv[1:] if argv is None else argv)
    if opts._helper:
        django_helper(opts._helper)
        return
    signal.signal(signal.SIGTERM, _on_sigterm)
    ensure_wrk()
    started = time.monotonic()
    dbs = ["sqlite", "postgres"] if opts.db == "both" else [opts.db]
    print(
        f"bench.server: {', '.join(dbs)}; {os.cpu_count()} CPUs; phases "
        f"{opts.phase_seconds:g} s, mixed run {opts.soak_seconds:g} s; "
        f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC; load average {os.getloadavg()[0]:.1f}"
    )
    try:
        for db in dbs:
            bench_db(db, opts)
    except KeyboardInterrupt:
        print("\ninterrupted: cleaning up", file=sys.stderr)
        raise SystemExit(130) from None
    finally:
        CLEANUP.run()
    print(f"\ntotal {time.monotonic() - started:.0f} s")


if __name__ == "__main__":
    main()
