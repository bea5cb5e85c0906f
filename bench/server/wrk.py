"""Load from wrk (Lua scripts in bench/lua), with the server's and wrk's CPU time per request."""

from __future__ import annotations

import json
import os
import resource
import subprocess
from dataclasses import dataclass
from pathlib import Path

from bench.server.constants import HOST
from bench.server.stack import Stack

LUA = Path(__file__).resolve().parents[1] / "lua"


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


def combine(runs: list[WrkResult]) -> WrkResult:
    """Several rounds of one load as one result: counts and seconds add up, latencies are
    weighted by each round's requests (an approximation: wrk reports no histogram)."""
    total = max(1, sum(r.requests for r in runs))

    def weighted(name: str) -> float:
        return sum(getattr(r, name) * r.requests for r in runs) / total

    return WrkResult(
        requests=sum(r.requests for r in runs),
        seconds=sum(r.seconds for r in runs),
        ok=sum(r.ok for r in runs),
        bad=sum(r.bad for r in runs),
        errors=sum(r.errors for r in runs),
        first_bad=next((r.first_bad for r in runs if r.first_bad), ""),
        p50_ms=weighted("p50_ms"),
        p90_ms=weighted("p90_ms"),
        p99_ms=weighted("p99_ms"),
        max_ms=max((r.max_ms for r in runs), default=0.0),
        cpu_ms=weighted("cpu_ms"),
        client_cpu_ms=weighted("client_cpu_ms"),
    )


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
