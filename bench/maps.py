"""Issue-9 speed benchmark: the map's reads over 1,000,000 fixes, beside the naive query.

    python -m bench.maps                  # SQLite; PostgreSQL too when DATABASE_URL is set
    python -m bench.maps --postgres       # both, PostgreSQL in a throwaway database
    python -m bench.maps --fixes 200000   # a smaller run
    python -m bench.maps --db postgres    # one database only

Per database, in a child process with its own settings (bench.settings, production-like,
DEBUG off): a fresh database (a temp SQLite file, or a throwaway PostgreSQL database dropped at
the end), one vessel with 1,000,000 fixes over 30 days (bulk insert: executemany / COPY) with
three one-hour silences, and 99 more vessels for the fleet poll. Then:

- the overview build (once, like `manage.py rebuild_track_overview` after a bulk load);
- each endpoint through the in-process Django test client: the whole middleware, auth and DRF
  stack, no socket. "Server time" is the median of several requests, from request to the last
  byte of the body; the wire size is the body's length;
- the naive query next to them: every fix of the range read through the ORM and serialised as
  a GeoJSON Feature (what the issue measured at 13-18 s and 68 MB);
- the track of a day and the month's plots with that day's minutes all marked out of date
  (read from the fixes until `rebuild_track_overview --loop` rebuilds them);
- the ingest cost of the overview's dirty marks: 500-fix batches with and without them;
- the export's rate and its memory: RSS growth while the whole range streams;
- beside the CSV export, its ceiling: the same bytes written with nothing between the database
  and them (PostgreSQL's ``COPY (…) TO STDOUT`` of the export's own line SQL; the ``sqlite3``
  CLI running it, or a raw sqlite3 cursor loop where the CLI is missing), checked byte for
  byte against the export on a day's range, then timed over the month.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import random
import resource
import shutil
import statistics
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from bench.child import databases, report
from bench.child import run_child as run_database_child

ROOT = Path(__file__).resolve().parents[1]
DAYS = 30
SILENCES_H = (100, 300, 500)  # hours into the month where the boat is silent for an hour
REPEATS = 7
FLEET_SIZE = 100
INGEST_BATCHES = 20
TARGETS = {
    "track 30 d": "≤ 50 ms SQLite, ≤ 100 ms PostgreSQL, ≤ 120 KB",
    "track 1 d": "≤ 20 ms",
    "series 30 d": "≤ 100 ms",
    "track 1 d, 1 d unbuilt": "(worst case before the loop)",
    "series 30 d, 1 d unbuilt": "(worst case before the loop)",
    "export csv": "≥ 250,000 fixes/s, flat memory",
    "csv ceiling": "baseline: the same bytes, no Django",
    "export geojson": "≥ 250,000 fixes/s, flat memory",
    "fleet 100": "≤ 20 ms, 304 when unchanged",
}


# --- the child: one database ---


def rss_kb() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def build_fixes(vessel_id: int, count: int, start: dt.datetime) -> None:
    """``count`` fixes over DAYS days, a slow survey pattern, straight into the table."""
    from django.db import connection, transaction

    from telemetry.models import Fix

    step = DAYS * 86400 / count
    silent = [(h * 3600, (h + 1) * 3600) for h in SILENCES_H]
    rng = random.Random(9)
    t0 = start.timestamp()

    def rows() -> Any:
        lat, lon = -32.0, 115.7
        for i in range(count):
            s = i * step
            if any(a <= s < b for a, b in silent):
                continue
            lat += 0.0002 * math.sin(i / 3000) + rng.uniform(-1e-5, 1e-5)
            lon += 0.0002 * math.cos(i / 5000) + rng.uniform(-1e-5, 1e-5)
            lat = max(-89.0, min(89.0, lat))
            yield (
                dt.datetime.fromtimestamp(t0 + s, dt.UTC),
                lat,
                lon,
                (i / 10) % 360,
                1.0 + (i % 20) / 10,
                12.0 + math.sin(i / 50_000) + (5.0 if i == count // 2 else 0.0),  # one spike
                {"water_temp_c": 18 + (i % 100) / 100, "salinity_psu": 35 + (i % 37) / 100},
            )

    table = Fix._meta.db_table
    columns = "vessel_id, recorded_at, received_at, lat, lon, heading_deg, speed_mps, battery_v, "
    columns += "readings"
    now = dt.datetime.now(dt.UTC)
    # One transaction: in autocommit SQLite would sync the file for every row.
    with transaction.atomic(), connection.cursor() as cursor:
        if connection.vendor == "postgresql":
            with cursor.cursor.copy(f"COPY {table} ({columns}) FROM STDIN") as copy:
                for t, lat, lon, h, s, b, r in rows():
                    copy.write_row((vessel_id, t, now, lat, lon, h, s, b, json.dumps(r)))
        else:
            adapt = connection.ops.adapt_datetimefield_value
            received = adapt(now)
            sql = f"INSERT INTO {table} ({columns}) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)"
            batch: list[tuple[Any, ...]] = []
            raw = cursor.cursor
            for t, lat, lon, h, s, b, r in rows():
                batch.append((vessel_id, adapt(t), received, lat, lon, h, s, b, json.dumps(r)))
                if len(batch) == 50_000:
                    raw.executemany(sql, batch)
                    batch = []
            raw.executemany(sql, batch)
        if connection.vendor == "postgresql":
            cursor.execute(f"ANALYZE {table}")


class Clock:
    """Wall and CPU time of this process: on a shared machine the wall time includes waiting
    for a core; the CPU time is the work (all of it on SQLite, in process; on PostgreSQL the
    server's own share runs in its process and is left out)."""

    def __enter__(self) -> Clock:
        self.wall, self.cpu = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc: object) -> None:
        self.wall = (time.perf_counter() - self.wall) * 1000
        self.cpu = (time.process_time() - self.cpu) * 1000


def timed(client: Any, url: str, repeats: int = REPEATS, **headers: Any) -> tuple[Any, ...]:
    """(median wall ms, median CPU ms, body bytes, last response) of GETs of ``url``."""
    walls, cpus, size, response = [], [], 0, None
    for _ in range(repeats):
        with Clock() as clock:
            response = client.get(url, **headers)
            body = b"".join(response.streaming_content) if response.streaming else response.content
        walls.append(clock.wall)
        cpus.append(clock.cpu)
        size = len(body)
        assert response.status_code in (200, 304), (url, response.status_code, body[:300])
    return statistics.median(walls), statistics.median(cpus), size, response


def naive_geojson(vessel: Any, start: dt.datetime, end: dt.datetime) -> tuple[float, float, int]:
    """The naive track: every fix through the ORM, one GeoJSON Feature each."""
    from telemetry.models import Fix

    with Clock() as clock:
        body = _naive_body(Fix, vessel, start, end)
    return clock.wall, clock.cpu, len(body)


def _naive_body(Fix: Any, vessel: Any, start: dt.datetime, end: dt.datetime) -> str:  # noqa: N803
    features = [
        {
            "type": "Feature",
            "geometry": {"type": "Point", "coordinates": [f.lon, f.lat]},
            "properties": {
                "time": f.recorded_at.isoformat(),
                "heading_deg": f.heading_deg,
                "speed_mps": f.speed_mps,
                "battery_v": f.battery_v,
                "readings": f.readings,
            },
        }
        for f in Fix.objects.filter(
            vessel=vessel, recorded_at__gte=start, recorded_at__lt=end
        ).order_by("recorded_at")
    ]
    return json.dumps({"type": "FeatureCollection", "features": features})


def ingest_cost(vessel: Any, start: dt.datetime) -> dict[str, float]:
    """ms per 500-fix batch of new fixes, with the overview's dirty marks and without."""
    from telemetry import services, sql

    def batches(first: float) -> list[list[dict[str, Any]]]:
        return [
            [
                {"time": first + (b * 500 + i) * 2.0, "lat": -32.0, "lon": 115.7,
                 "battery_v": 12.5, "readings": {"water_temp_c": 18.0}}
                for i in range(500)
            ]
            for b in range(INGEST_BATCHES)
        ]  # fmt: skip

    def run(records: list[list[dict[str, Any]]]) -> float:
        started = time.perf_counter()
        for batch in records:
            services.fix_ingest(vessel=vessel, records=batch)
        return (time.perf_counter() - started) * 1000 / len(records)

    base = start.timestamp() + DAYS * 86400 + 3600
    with_marks = run(batches(base))
    refresh_started = time.perf_counter()
    services.track_overview_refresh(vessel_id=vessel.pk)
    refresh = (time.perf_counter() - refresh_started) * 1000 / INGEST_BATCHES
    mark, cte = sql.mark_dirty, sql.mark_dirty_cte
    sql.mark_dirty = lambda vessel_id, times: None  # type: ignore[assignment]
    sql.mark_dirty_cte = lambda: "dirty AS (SELECT %s)"  # type: ignore[assignment]
    try:
        without = run(batches(base + 86400))
    finally:
        sql.mark_dirty, sql.mark_dirty_cte = mark, cte
    return {"with": with_marks, "without": without, "refresh": refresh}


def export_run(client: Any, url: str) -> tuple[float, float, float, int]:
    """(wall ms, CPU ms, RSS growth MB, bytes) of one streamed export, read chunk by chunk."""
    before = peak = rss_kb()
    size = 0
    with Clock() as clock:
        response = client.get(url)
        for i, chunk in enumerate(response.streaming_content):
            size += len(chunk)
            if i % 20 == 0:
                peak = max(peak, rss_kb())
    return clock.wall, clock.cpu, (max(peak, rss_kb()) - before) / 1024, size


def csv_ceiling(
    vessel_id: int, start: dt.datetime, end: dt.datetime
) -> tuple[str, Iterator[bytes]]:
    """The CSV export's bytes for [start, end) written with nothing between the database and
    them: (how, a generator of byte blocks). The export's own line SQL, so the same text."""
    from django.db import connection

    from telemetry import sql as telemetry_sql
    from telemetry.api import export

    sql, params = telemetry_sql.fixes_sql(vessel_id, start, end, telemetry_sql.csv_line_sql())
    header = export.CSV_HEADER.encode()
    if connection.vendor == "postgresql":
        return "COPY (…) TO STDOUT", _copy_blocks(connection, sql, params, header)
    if shutil.which("sqlite3"):
        return "sqlite3 CLI", _cli_blocks(connection, sql, params, header)
    return "raw sqlite3 cursor", _cursor_blocks(connection, sql, params, header)


def _copy_blocks(connection: Any, sql: str, params: list[Any], header: bytes) -> Iterator[bytes]:
    # COPY's text format ends a row with LF: each row becomes CRLF like the export's. (It
    # would also double a backslash; the benchmark's readings have none, and the byte check
    # would catch one.)
    yield header
    with (
        connection.cursor() as cursor,
        cursor.cursor.copy(f"COPY ({sql}) TO STDOUT", params) as copy,
    ):
        for block in copy:
            yield bytes(block).replace(b"\n", b"\r\n")


def _cli_blocks(connection: Any, sql: str, params: list[Any], header: bytes) -> Iterator[bytes]:
    # The CLI takes no parameters: ours are an integer and times as text.
    parts = sql.split("%s")
    literals = [
        str(p) if isinstance(p, int) else "'" + str(p).replace("'", "''") + "'" for p in params
    ]
    text = "".join(part + value for part, value in zip(parts, [*literals, ""], strict=True))
    argv = ["sqlite3", "-batch", "-noheader", "-list", "-separator", "", "-newline", "\r\n"]
    argv += [connection.settings_dict["NAME"], text]
    yield header
    with subprocess.Popen(argv, stdout=subprocess.PIPE) as proc:
        assert proc.stdout is not None
        while block := proc.stdout.read(1 << 20):
            yield block
    assert proc.returncode == 0, proc.returncode


def _cursor_blocks(connection: Any, sql: str, params: list[Any], header: bytes) -> Iterator[bytes]:
    yield header
    connection.ensure_connection()
    cursor = connection.connection.cursor()
    cursor.execute(sql.replace("%s", "?"), params)
    while rows := cursor.fetchmany(5000):
        yield ("\r\n".join(row[0] for row in rows) + "\r\n").encode()


def ceiling_run(
    client: Any,
    vessel_id: int,
    check: tuple[dt.datetime, dt.datetime],
    url: str,
    whole: tuple[dt.datetime, dt.datetime],
) -> tuple[float, float, int, str]:
    """(wall ms, CPU ms, bytes, how) of the CSV ceiling over the ``whole`` range, once it
    wrote the same bytes as the export (``url``) over the ``check`` range. The CPU time counts
    the sqlite3 CLI's too; PostgreSQL's server share is left out, as for the export."""
    how, blocks = csv_ceiling(vessel_id, *check)
    exported = b"".join(client.get(url).streaming_content)
    assert b"".join(blocks) == exported, f"{how} wrote other bytes than the export"
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    with Clock() as clock:
        how, blocks = csv_ceiling(vessel_id, *whole)
        size = sum(len(block) for block in blocks)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cli_ms = (after.ru_utime + after.ru_stime - children.ru_utime - children.ru_stime) * 1000
    return clock.wall, clock.cpu + cli_ms, size, how


def child(opts: argparse.Namespace) -> None:
    import django

    django.setup()
    from django.contrib.auth.models import Permission, User
    from django.core.management import call_command
    from django.db import connection
    from django.test import Client

    from telemetry.models import Fix, TrackDirty
    from telemetry.services import track_overview_rebuild
    from vessels.services import vessel_create, vessel_record_fix

    results: dict[str, Any] = {"db": connection.vendor, "fixes": opts.fixes}
    call_command("migrate", verbosity=0)
    vessel = vessel_create(slug="survey", name="Survey", kind="mavlink", telemetry_period_s=3)
    start = dt.datetime(2026, 10, 1, tzinfo=dt.UTC)
    end = start + dt.timedelta(days=DAYS)

    started = time.perf_counter()
    build_fixes(vessel.pk, opts.fixes, start)
    results["load_s"] = time.perf_counter() - started
    stored = Fix.objects.filter(vessel=vessel).count()
    results["stored"] = stored
    started = time.perf_counter()
    track_overview_rebuild(vessel=vessel)
    results["overview_build_s"] = time.perf_counter() - started

    user = User.objects.create_user("bench", is_staff=True)
    for codename in ("view_vessel", "view_fix"):
        user.user_permissions.add(Permission.objects.get(codename=codename))
    client = Client()
    client.force_login(user)

    def q(a: dt.datetime, b: dt.datetime) -> str:
        return f"from={a.timestamp():.0f}&to={b.timestamp():.0f}"

    base = "/api/v1/vessels/survey"
    day = (start + dt.timedelta(days=12), start + dt.timedelta(days=13))
    figures: dict[str, Any] = {}
    ms, cpu, size, response = timed(client, f"{base}/track/?{q(start, end)}")
    points = json.loads(response.content)["features"][0]["properties"]["points"]
    figures["track 30 d"] = (ms, cpu, size, f"{points} points")
    ms, cpu, size, response = timed(client, f"{base}/track/?{q(*day)}")
    points = json.loads(response.content)["features"][0]["properties"]["points"]
    figures["track 1 d"] = (ms, cpu, size, f"{points} points")
    ms, cpu, size, response = timed(client, f"{base}/series/?{q(start, end)}")
    body = json.loads(response.content)
    spike = max(v for v in body["channels"]["battery_v"]["max"] if v is not None)
    figures["series 30 d"] = (ms, cpu, size, f"{len(body['t'])} buckets, max {spike:.2f} V")
    # Reads never rebuild: minutes marked out of date are read from their fixes until the
    # background loop rebuilds them. The worst a read meets: a whole day of them.
    marks = [TrackDirty(vessel=vessel, start=int(day[0].timestamp()) + 60 * m) for m in range(1440)]
    TrackDirty.objects.bulk_create(marks)
    ms, cpu, size, response = timed(client, f"{base}/track/?{q(*day)}")
    points = json.loads(response.content)["features"][0]["properties"]["points"]
    figures["track 1 d, 1 d unbuilt"] = (ms, cpu, size, f"{points} points")
    ms, cpu, size, response = timed(client, f"{base}/series/?{q(start, end)}")
    figures["series 30 d, 1 d unbuilt"] = (ms, cpu, size, f"{len(body['t'])} buckets")
    TrackDirty.objects.filter(vessel=vessel).delete()  # the buckets are right: only unmark
    for fmt in ("csv", "geojson"):
        url = f"{base}/track/export/?{q(start, end)}&format={fmt}"
        ms, cpu, grown, size = export_run(client, url)
        rates = f"{stored / ms * 1000:,.0f} /s wall, {stored / cpu * 1000:,.0f} /s CPU"
        figures[f"export {fmt}"] = (ms, cpu, size, f"{rates}, RSS +{grown:.0f} MB")
        if fmt == "csv":
            export_ms = ms
            check_url = f"{base}/track/export/?{q(*day)}&format=csv"
            ms, cpu, size, how = ceiling_run(client, vessel.pk, day, check_url, (start, end))
            rates = f"{stored / ms * 1000:,.0f} /s wall, {stored / cpu * 1000:,.0f} /s CPU"
            share = f"export at {ms / export_ms:.0%}"
            figures["csv ceiling"] = (ms, cpu, size, f"{rates}, {how}, {share}")

    now = dt.datetime.now(dt.UTC)
    for i in range(FLEET_SIZE - 1):
        other = vessel_create(slug=f"boat-{i}", name=f"Boat {i:03}", kind="mavlink")
        if i % 3:
            summary = {"time": now.isoformat(), "lat": -32.0 + i / 100, "lon": 115.7,
                       "heading_deg": 10.0 * (i % 36), "battery_v": 12.5}  # fmt: skip
            vessel_record_fix(vessel_id=other.pk, seen_at=now, fix_at=now, summary=summary)
    ms, cpu, size, response = timed(client, "/api/v1/fleet/")
    ms_304, cpu_304, _, not_modified = timed(
        client, "/api/v1/fleet/", HTTP_IF_NONE_MATCH=response["ETag"]
    )
    detail = f"{not_modified.status_code} in {ms_304:.1f} ms ({cpu_304:.1f} CPU)"
    figures["fleet 100"] = (ms, cpu, size, detail)

    results["figures"] = figures
    results["ingest"] = ingest_cost(vessel, start)
    if not opts.skip_naive:
        results["naive"] = naive_geojson(vessel, start, end)
    report(results)


# --- the parent: a child per database, then the table ---


def run_child(db: str, opts: argparse.Namespace) -> dict[str, Any]:
    args = ["--fixes", str(opts.fixes), *(["--skip-naive"] if opts.skip_naive else [])]
    return run_database_child("bench.maps", db, args)


def print_table(r: dict[str, Any]) -> None:
    print(
        f"\n### {r['db']}: {r['stored']:,} fixes over {DAYS} days (loaded in "
        f"{r['load_s']:.1f} s; overview built in {r['overview_build_s']:.1f} s)"
    )
    print(f"{'figure':<25} {'wall ms':>9} {'CPU ms':>9} {'bytes':>12}  {'detail':<48} target")
    for name, (ms, cpu, size, detail) in r["figures"].items():
        print(f"{name:<25} {ms:>9.1f} {cpu:>9.1f} {size:>12,}  {detail:<48} {TARGETS[name]}")
    if "naive" in r:
        ms, cpu, size = r["naive"]
        what = "every fix a Feature (ORM), same range"
        print(f"{'naive geojson':<25} {ms:>9.1f} {cpu:>9.1f} {size:>12,}  {what:<48} baseline")
    i = r["ingest"]
    print(f"ingest of a 500-fix batch: {i['with']:.1f} ms with the overview's dirty marks, "
          f"{i['without']:.1f} ms without; their rebuild costs {i['refresh']:.1f} ms "
          "per batch, once, in the background loop")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m bench.maps", description=__doc__.split("\n")[0])
    p.add_argument("--fixes", type=int, default=1_000_000)
    p.add_argument("--postgres", action="store_true", help="also PostgreSQL (127.0.0.1)")
    p.add_argument("--db", choices=["sqlite", "postgres"], help="only this database")
    p.add_argument("--skip-naive", action="store_true", help="leave out the naive baseline")
    p.add_argument("--_child", action="store_true", help=argparse.SUPPRESS)
    opts = p.parse_args(argv)
    if opts._child:
        child(opts)
        return 0
    for db in databases(opts.postgres, opts.db):
        print(f"- {db}: building {opts.fixes:,} fixes and measuring ...", flush=True)
        print_table(run_child(db, opts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
