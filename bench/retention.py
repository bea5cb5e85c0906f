"""Issue-19 speed benchmark: thinning 1,000,000 fixes while a boat keeps posting.

    python -m bench.retention                  # SQLite; PostgreSQL too when DATABASE_URL is set
    python -m bench.retention --postgres       # both, PostgreSQL in a throwaway database
    python -m bench.retention --fixes 200000   # a smaller run
    python -m bench.retention --db postgres    # one database only

Per database, in a child process with production-like settings (bench.settings, DEBUG off): a
fresh database holding one vessel with 1,000,000 fixes a second old enough to thin (generated
by the database itself: a recursive CTE on SQLite, generate_series on PostgreSQL), its track
overview built. Then, each time beside an ingest loop in another process that posts one fix
every TICK_S through the ingest service (fix_ingest, what the boat API calls) to the same
vessel and times every post:

1. **baseline**: the ingest loop alone, as long as the prune took (measured second);
2. **prune**: `fixes_prune` thins the million to the first and last fix of each minute, and
   rebuilds the track overview of the minutes it thinned as it goes (none is left for
   `rebuild_track_overview --loop`: counted).

Printed: the prune's rate (fixes read and deleted per second) and its longest transaction, and
per phase the ingest's posts, their median, 99th percentile and worst time ("pause"), how many
took longer than 100 ms (the issue's target: none), and the same less the time the ingest
process waited for a CPU meanwhile (/proc/self/schedstat): on a shared machine a post also
waits when it, or the prune holding SQLite's lock, is not running.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from bench.child import databases, report
from bench.child import run_child as run_database_child

ROOT = Path(__file__).resolve().parents[1]
TICK_S = 0.01  # the ingest loop posts a fix every 10 ms (as 100 boats at 1 Hz would)
TARGET_MS = 100.0
RETENTION_DAYS = 1
INTERVAL_S = 60
BASELINE_CAP_S = 120.0


# --- the ingest loop: its own process (its own connection, its own interpreter lock) ---


def ingest_loop(vessel_id: int) -> None:
    import django

    django.setup()
    from django.utils import timezone

    from telemetry.services import fix_ingest
    from vessels.models import Vessel

    vessel = Vessel.objects.get(pk=vessel_id)
    stop = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), stop.set()), daemon=True).start()
    times: list[tuple[float, float]] = []
    print("ready", flush=True)
    next_at = time.perf_counter()
    i = 0
    while not stop.is_set():
        now = timezone.now()
        record = {"time": now.isoformat(), "lat": -32 + i * 1e-6, "lon": 115.7, "battery_v": 12.4}
        queued, started = run_delay_ms(), time.perf_counter()
        result = fix_ingest(vessel=vessel, records=[record], now=now)
        times.append(((time.perf_counter() - started) * 1000, run_delay_ms() - queued))
        assert result.accepted == 1, result
        i += 1
        next_at += TICK_S
        time.sleep(max(0.0, next_at - time.perf_counter()))
    print("@@INGEST " + json.dumps(times), flush=True)


def run_delay_ms() -> float:
    """How long this process has waited for a CPU, all told (Linux schedstat; 0 elsewhere):
    on a shared machine a post can stall because the ingest itself was not running."""
    try:
        return int(Path("/proc/self/schedstat").read_text().split()[1]) / 1e6
    except (OSError, IndexError, ValueError):
        return 0.0


def beside_ingest(vessel_id: int, action: Callable[[], Any]) -> tuple[Any, dict[str, Any]]:
    """Run ``action`` while the ingest loop posts; (its result, the posts' figures)."""
    argv = [sys.executable, "-m", "bench.retention", "--_ingest", str(vessel_id)]
    loop = subprocess.Popen(
        argv, cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert loop.stdin and loop.stdout
    assert loop.stdout.readline().strip() == "ready"
    time.sleep(1.0)  # past the loop's first posts (connection, caches)
    started = time.perf_counter()
    result = action()
    seconds = time.perf_counter() - started
    loop.stdin.close()  # the loop's signal to stop and report
    out = loop.stdout.read()
    loop.wait(60)
    times = next(
        json.loads(line.removeprefix("@@INGEST "))
        for line in out.splitlines()
        if line.startswith("@@INGEST ")
    )
    walls = sorted(wall for wall, _ in times)
    # A post's time less the time the ingest waited for a CPU meanwhile: what the database
    # (and the prune) made it wait.
    waits = sorted(max(0.0, wall - queued) for wall, queued in times)
    return result, {
        "seconds": seconds,
        "posts": len(walls),
        "median": statistics.median(walls),
        "p99": walls[int(len(walls) * 0.99)],
        "max": walls[-1],
        "over": sum(t > TARGET_MS for t in walls),
        "max_running": waits[-1],
        "over_running": sum(t > TARGET_MS for t in waits),
    }


# --- the child: one database ---


def load(vessel_id: int, count: int, start: dt.datetime) -> None:
    """``count`` fixes one second apart from ``start``, received five seconds later, generated
    by the database (no Python per row)."""
    from django.db import connection, transaction

    from telemetry.models import Fix

    table = connection.ops.quote_name(Fix._meta.db_table)
    columns = (
        "vessel_id, recorded_at, received_at, lat, lon, heading_deg, speed_mps, battery_v, readings"
    )
    values = (
        "-32 + (i %% 1000) / 100000.0, 115.7 + (i %% 777) / 100000.0, i %% 360, 1.5,"
        " 12 + (i %% 50) / 100.0"
    )
    t0 = int(start.timestamp())
    with transaction.atomic(), connection.cursor() as cursor:
        if connection.vendor == "postgresql":
            cursor.execute(
                f"INSERT INTO {table} ({columns}) SELECT %s, to_timestamp(%s + i),"
                f" to_timestamp(%s + i + 5), {values},"
                " jsonb_build_object('water_temp_c', 18 + (i %% 7) / 10.0)"
                " FROM generate_series(0, %s - 1) AS i",
                [vessel_id, t0, t0, count],
            )
            cursor.execute(f"ANALYZE {table}")
        else:
            stamp = "strftime('%%Y-%%m-%%d %%H:%%M:%%S', %s + i{}, 'unixepoch')"
            cursor.execute(
                "WITH RECURSIVE n(i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM n WHERE i < %s - 1)"
                f" INSERT INTO {table} ({columns}) SELECT %s, {stamp.format('')},"
                f" {stamp.format(' + 5')}, {values},"
                " json_object('water_temp_c', 18 + (i %% 7) / 10.0) FROM n",
                [count, vessel_id, t0, t0],
            )


def child(opts: argparse.Namespace) -> None:
    import django

    django.setup()
    from django.core.management import call_command
    from django.db import connection

    from telemetry.models import Fix, TrackDirty
    from telemetry.retention import fixes_prune
    from telemetry.services import track_overview_rebuild
    from vessels.services import vessel_create

    call_command("migrate", verbosity=0)
    vessel = vessel_create(slug="survey", name="Survey", telemetry_period_s=1)
    start = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)
    now = start + dt.timedelta(seconds=opts.fixes, days=RETENTION_DAYS + 1)
    results: dict[str, Any] = {"db": connection.vendor, "fixes": opts.fixes}
    started = time.perf_counter()
    load(vessel.pk, opts.fixes, start)
    results["load_s"] = time.perf_counter() - started
    started = time.perf_counter()
    track_overview_rebuild(vessel=vessel)
    results["overview_s"] = time.perf_counter() - started

    def prune() -> Any:
        return fixes_prune(now=now, older_than_days=RETENTION_DAYS, interval_s=INTERVAL_S)

    pruned, results["prune"] = beside_ingest(vessel.pk, prune)
    results["examined"], results["deleted"] = pruned.examined, pruned.deleted
    results["transactions"], results["hold_ms"] = pruned.transactions, pruned.longest_hold_s * 1000
    results["left"] = Fix.objects.filter(vessel=vessel, recorded_at__lt=pruned.cutoff).count()
    cutoff = pruned.cutoff.timestamp()
    results["marks"] = TrackDirty.objects.filter(vessel=vessel, start__lt=cutoff).count()
    baseline_s = min(results["prune"]["seconds"], BASELINE_CAP_S)
    _, results["baseline"] = beside_ingest(vessel.pk, lambda: time.sleep(baseline_s))
    report(results)


# --- the parent: a child per database, then the table ---


def run_child(db: str, opts: argparse.Namespace) -> dict[str, Any]:
    return run_database_child("bench.retention", db, ["--fixes", str(opts.fixes)])


def print_table(r: dict[str, Any]) -> None:
    print(
        f"\n### {r['db']}: {r['fixes']:,} fixes, 1 a second (loaded in {r['load_s']:.1f} s,"
        f" overview built in {r['overview_s']:.1f} s); thinned to the first and last of each"
        f" {INTERVAL_S} s"
    )
    print(
        f"prune: {r['examined']:,} read, {r['deleted']:,} deleted, {r['left']:,} left, in"
        f" {r['prune']['seconds']:.1f} s = {r['examined'] / r['prune']['seconds']:,.0f} fixes/s"
        f" ({r['deleted'] / r['prune']['seconds']:,.0f} deletions/s); {r['transactions']:,}"
        f" transactions, the longest {r['hold_ms']:.1f} ms; {r['marks']:,} thinned minutes left"
        " out of date"
    )
    print(
        f"{'ingest, one fix a post':<34} {'s':>6} {'posts':>7} {'median ms':>10} {'p99 ms':>8}"
        f" {'max ms':>8} {'>100 ms':>8} {'max ms, CPU wait out':>21} {'>100 ms':>8}"
    )
    for name, key in (
        ("baseline: ingest alone", "baseline"),
        ("while the prune runs", "prune"),
    ):
        f = r[key]
        print(
            f"{name:<34} {f['seconds']:>6.1f} {f['posts']:>7,} {f['median']:>10.2f}"
            f" {f['p99']:>8.2f} {f['max']:>8.1f} {f['over']:>8} {f['max_running']:>21.1f}"
            f" {f['over_running']:>8}"
        )
    print(
        f"target: thinning never pauses ingest more than {TARGET_MS:.0f} ms. 'CPU wait out':"
        " each post's time less the time the ingest process waited for a CPU meanwhile"
        " (/proc/self/schedstat), on a machine shared with other work"
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m bench.retention", description=__doc__.split("\n")[0]
    )
    p.add_argument("--fixes", type=int, default=1_000_000)
    p.add_argument("--postgres", action="store_true", help="also PostgreSQL (127.0.0.1)")
    p.add_argument("--db", choices=["sqlite", "postgres"], help="only this database")
    p.add_argument("--_child", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--_ingest", type=int, help=argparse.SUPPRESS)
    opts = p.parse_args(argv)
    if opts._ingest:
        ingest_loop(opts._ingest)
        return 0
    if opts._child:
        child(opts)
        return 0
    for db in databases(opts.postgres, opts.db):
        print(f"- {db}: loading {opts.fixes:,} fixes and thinning them ...", flush=True)
        print_table(run_child(db, opts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
