"""Issue-19 speed benchmark: one alerts evaluator pass over 1,000 vessels and 100 rules.

    python -m bench.alerts                 # SQLite; PostgreSQL too when DATABASE_URL is set
    python -m bench.alerts --postgres      # both, PostgreSQL in a throwaway database
    python -m bench.alerts --db postgres   # one database only
    python -m bench.alerts --ingest-s 60   # longer ingest runs (default 20 s of each)

Per database, in a child process (bench.settings, DEBUG off) on a fresh database:

- the fleet: 1,000 vessels (900 ArduPilot boats reporting every 10 s, 100 gliders every 600 s),
  two days of hourly battery means in the track overview (for endurance), 10 fences (polygons
  of 24 vertices and circles), two sensor channels with limits;
- 100 rules: 25 overdue, 20 battery, 20 reading, 10 endurance, 15 fence, 10 command; a third
  for every vessel, a third for one kind, a third for one vessel; each with a channel;
- **one pass**: every vessel posts one fix (one period's worth, through the ingest service;
  about 2 % cross a limit one way or the other), then one evaluator pass is timed. Median of
  several periods; the pass at an hour's turn (the endurance means read again) separately;
- beside it, in the same run: **the reads alone** (the pass's queries, no judging: its floor)
  and **the naive loop** (for each rule, for each vessel: its new fixes and its active alert
  through the ORM, two queries per pair), timed on 5 rules and scaled to 100;
- **ingest with and without the evaluator**: single-fix posts through the ingest service in
  this process, in 2-second windows, alternately alone and with `manage.py run_alerts` beside
  it (a process of its own, at the default period, as deployed); fixes per second, the
  median of each;
- **fence to webhook**: when the notifications sender is there (alerts/services/
  notifications.py ``notifications_send_due``), a local HTTP receiver as a webhook channel,
  `run_alerts` at the default period, a fix posted outside a fence at a random moment, the
  time until the POST arrives; without the sender, until the alert is open.
"""

from __future__ import annotations

import argparse
import datetime as dt
import http.server
import json
import os
import random
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from bench.child import databases, report
from bench.child import run_child as run_database_child

ROOT = Path(__file__).resolve().parent.parent
VESSELS, GLIDERS = 1000, 100
PERIODS = 7  # timed passes per database (median)
RULE_MIX = [("overdue", 25), ("battery", 20), ("reading", 20), ("endurance", 10),
            ("fence", 15), ("command", 10)]  # fmt: skip


def build_fleet(rng: random.Random) -> dict[str, Any]:
    """Vessels, channels, fences, overview buckets and rules, straight into the tables."""
    from django.utils import timezone

    from alerts.models import AlertRule, NotificationChannel
    from telemetry.models import SensorChannel, TrackBucket
    from vessels.models import Fence, Vessel

    now = timezone.now()
    vessels = Vessel.objects.bulk_create(
        Vessel(
            slug=f"v{i:04d}",
            name=f"Vessel {i}",
            kind="wave_glider" if i < GLIDERS else "mavlink",
            telemetry_period_s=600 if i < GLIDERS else 10,
            last_seen_at=now,
        )
        for i in range(VESSELS)
    )
    SensorChannel.objects.create(key="humidity_pct", label="Hull humidity", minimum=0, maximum=70)
    SensorChannel.objects.create(key="water_temp_c", label="Water", minimum=5, maximum=35)
    fences = []
    for i in range(8):
        lat, lon = -32.0 + i * 0.01, 115.7
        if i % 2:
            geometry = {"type": "Point", "coordinates": [lon, lat]}
            fences.append(Fence(name=f"circle {i}", geometry=geometry, radius_m=20_000))
        else:
            ring = [[lon + 0.3 * _cos(k), lat + 0.3 * _sin(k)] for k in range(24)]
            geometry = {"type": "Polygon", "coordinates": [[*ring, ring[0]]]}
            fences.append(Fence(name=f"poly {i}", geometry=geometry))
    fences += [  # two exclusion zones a degree north, where only the odd fixes go
        Fence(name=f"reef {i}", geometry={"type": "Point", "coordinates": [115.7, lat]},
              radius_m=15_000, inclusion=False)
        for i, lat in enumerate((-31.0, -30.9))
    ]  # fmt: skip
    fences = Fence.objects.bulk_create(fences)
    hour = int(now.timestamp()) // 3600 * 3600
    TrackBucket.objects.bulk_create(
        (
            TrackBucket(
                vessel=v,
                width=3600,
                start=hour - 3600 * k,
                count=360,
                points=[],
                channels={"": [11.5, 13, (12.6 - 0.002 * (49 - k)) * 360, 360]},
            )  # fmt: skip
            for v in vessels
            for k in range(1, 50)
        ),
        batch_size=2000,
    )
    # E-mail to Django's in-memory outbox (run_child sets EMAIL_BACKEND): sent for real by the
    # sender, at no network's pace; a flood of them is summarised.
    channel = NotificationChannel.objects.create(name="ops", kind="email", target="ops@example.org")
    rules, n = [], 0
    for kind, count in RULE_MIX:
        for _ in range(count):
            scope = n % 3
            rule = AlertRule(
                name=f"{kind} {n}",
                kind=kind,
                vessel=vessels[rng.randrange(VESSELS)] if scope == 2 else None,
                vessel_kind="mavlink" if scope == 1 else "",
                threshold={"overdue": 3, "battery": 11.5, "endurance": 12}.get(kind),
                reading=rng.choice(["humidity_pct", "water_temp_c"]) if kind == "reading" else "",
                fence=fences[n % 10] if kind == "fence" else None,
            )
            rules.append(rule)
            n += 1
    rules = AlertRule.objects.bulk_create(rules)
    AlertRule.channels.through.objects.bulk_create(
        AlertRule.channels.through(alertrule_id=r.pk, notificationchannel_id=channel.pk)
        for r in rules
    )
    return {"vessels": vessels, "fences": fences}


def _cos(k: int) -> float:
    import math

    return math.cos(2 * math.pi * k / 24) * (1.0 + 0.3 * (k % 2))  # a jagged coastline


def _sin(k: int) -> float:
    import math

    return math.sin(2 * math.pi * k / 24) * (1.0 + 0.3 * (k % 2))


# Vessels beyond their limits: 2 % of the fleet. In a quiet period they stay so; in a busy one
# FLIPS of them come back and as many others go (a battery sags or recovers, a boat strays out
# or back): each such vessel is watched by ~30 rules, so a busy pass opens and resolves ~180
# episodes, far more than a real fleet's every ten seconds. An odd vessel stays put (inside a
# reef), so it does not cross in and out of fences by chance.
ODD_SHARE, FLIPS = 0.02, 3
odd_vessels: set[int] = set()


def one_period(vessels: list[Any], rng: random.Random, flips: int = 0) -> None:
    """Every vessel posts one fix now; the odd ones beyond their limits."""
    from django.utils import timezone

    from telemetry.services import fix_ingest

    now = timezone.now()
    if not odd_vessels:
        odd_vessels.update(v.pk for v in rng.sample(vessels, int(len(vessels) * ODD_SHARE)))
    else:
        back = rng.sample(sorted(odd_vessels), flips)
        odd_vessels.difference_update(back)
        odd_vessels.update(v.pk for v in rng.sample(vessels, flips))
    for v in vessels:
        odd = v.pk in odd_vessels
        record = {
            "time": now.isoformat(),
            # Normal ones well inside every inclusion fence (the nearest edge is 13 km away).
            "lat": -31.0 + rng.uniform(-0.01, 0.01) if odd else -32.0 + rng.uniform(-0.05, 0.05),
            "lon": 115.7 + rng.uniform(-0.05, 0.05),
            "battery_v": round(rng.uniform(11.0, 11.4) if odd else rng.uniform(12.0, 12.8), 2),
            "readings": {
                "humidity_pct": round(rng.uniform(75, 90) if odd else rng.uniform(30, 50), 1),
                "water_temp_c": round(rng.uniform(15, 25), 1),
            },
        }
        fix_ingest(vessel=v, records=[record])


def timed_passes(built: dict[str, Any], rng: random.Random) -> dict[str, Any]:
    from alerts.evaluator import Evaluator
    from alerts.models import Alert

    evaluator = Evaluator()
    one_period(built["vessels"], rng)
    first = _timed(evaluator.run_pass)
    passes, reports = [], []
    for _ in range(PERIODS):
        one_period(built["vessels"], rng)
        seconds, report = _timed(evaluator.run_pass)
        passes.append(seconds)
        reports.append(report)
    busy, busy_reports = [], []
    for _ in range(PERIODS):
        one_period(built["vessels"], rng, FLIPS)
        seconds, report = _timed(evaluator.run_pass)
        busy.append(seconds)
        busy_reports.append(report)
    # The hour's turn: every vessel's endurance means are brought up to date.
    evaluator.hourly = {v: (hour - 3600, means) for v, (hour, means) in evaluator.hourly.items()}
    one_period(built["vessels"], rng)
    rollover, _ = _timed(evaluator.run_pass)
    return {
        "first_s": first[0],
        "pass_s": statistics.median(passes),
        "pass_max_s": max(passes),
        "rollover_s": rollover,
        "fixes": reports[-1].fixes,
        "opened": sum(r.opened for r in reports),
        "resolved": sum(r.resolved for r in reports),
        "busy_s": statistics.median(busy),
        "busy_max_s": max(busy),
        "busy_changes": statistics.median(r.opened + r.resolved for r in busy_reports),
        "alerts": Alert.objects.count(),
    }


def reads_alone(rng: random.Random, built: dict[str, Any]) -> float:
    """The pass's reads with nothing judged: its floor."""
    from alerts.evaluator import Evaluator, active_rules

    evaluator = Evaluator()
    one_period(built["vessels"], rng)

    def reads() -> None:
        # The endurance reads happen once an hour; an ordinary pass's floor leaves them out.
        evaluator.snapshot(active_rules(), evaluator.fix_cursor)

    return _timed(reads)[0]


def naive(rng: random.Random, built: dict[str, Any], sample: int = 5) -> float:
    """For each rule, for each vessel: its new fixes and its active alert (ORM), scaled."""
    from django.utils import timezone

    from alerts.models import ACTIVE_STATES, Alert, AlertRule
    from telemetry.models import Fix
    from vessels.models import Vessel

    since = timezone.now()
    one_period(built["vessels"], rng)
    rules = list(AlertRule.objects.filter(vessel__isnull=True).order_by("pk")[:sample])
    started = time.perf_counter()
    for rule in rules:
        vessels = Vessel.objects.filter(active=True)
        if rule.vessel_kind:
            vessels = vessels.filter(kind=rule.vessel_kind)
        for vessel in vessels:
            list(Fix.objects.filter(vessel=vessel, received_at__gte=since).order_by("recorded_at"))
            Alert.objects.filter(rule=rule, vessel=vessel, state__in=ACTIVE_STATES).first()
    per_rule = (time.perf_counter() - started) / len(rules)
    return per_rule * 100


def ingest_rates(built: dict[str, Any], seconds: float, env: dict[str, str]) -> dict[str, Any]:
    """Single-fix posts in short windows, alternately alone and with `run_alerts` beside them:
    on a shared machine the load changes by the second, so windows side by side compare
    better than two long runs apart. Medians of each."""
    from django.utils import timezone

    from telemetry.services import fix_ingest

    vessels = built["vessels"][GLIDERS:]
    rng = random.Random(5)
    window = 2.0

    def run() -> float:
        count, end = 0, time.perf_counter() + window
        while time.perf_counter() < end:
            v = vessels[rng.randrange(len(vessels))]
            t = timezone.now() + dt.timedelta(microseconds=rng.randrange(1_000_000))
            fix_ingest(vessel=v, records=[{"time": t.isoformat(), "lat": -32.0, "lon": 115.7,
                                           "battery_v": 12.4}])  # fmt: skip
            count += 1
        return count / window

    without, with_, cpu = [], [], 0.0
    for _ in range(max(2, int(seconds / window))):
        without.append(run())
        # A fresh loop each time, settled (its first pass done) before the window; stopped
        # with SIGTERM after it, which it obeys between passes, never inside a transaction
        # (pausing it with SIGSTOP could hold SQLite's write lock over the next window).
        proc = _run_alerts(env)
        try:
            time.sleep(2.5)
            before = _cpu_s(proc.pid)
            with_.append(run())
            cpu += _cpu_s(proc.pid) - before
        finally:
            _stop(proc)
    return {"without": statistics.median(without), "with": statistics.median(with_),
            "evaluator_cpu": cpu / (window * len(with_)), "load": os.getloadavg()[0],
            "cores": os.cpu_count(), "windows": len(with_)}  # fmt: skip


def _cpu_s(pid: int) -> float:
    """CPU seconds (user + system) a process has used so far (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def fence_latency(built: dict[str, Any], env: dict[str, str], trials: int) -> dict[str, Any]:
    """A fix outside a fence, at a random moment; seconds until the webhook's POST arrives
    (or, without a sender, until the alert is open)."""
    from django.utils import timezone

    from alerts.models import Alert, AlertRule, NotificationChannel
    from alerts.services import notifications
    from telemetry.services import fix_ingest
    from vessels.models import Fence, Vessel

    # (when, alert id) of each alert.opened POST: a trial times its own alert's, not a late
    # resolve or an earlier trial's.
    arrived: list[tuple[float, int]] = []

    class Receiver(http.server.BaseHTTPRequestHandler):
        def do_POST(self) -> None:  # noqa: N802
            body = json.loads(self.rfile.read(int(self.headers.get("Content-Length", 0))))
            if body.get("event") == "alert.opened":
                arrived.append((time.perf_counter(), body["alert"]["id"]))
            self.send_response(204)
            self.end_headers()

        def log_message(self, *args: Any) -> None:
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Receiver)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    sender = hasattr(notifications, "notifications_send_due")
    hook = NotificationChannel.objects.create(
        name="receiver", kind="webhook", target=f"http://127.0.0.1:{server.server_port}/",
        secret="bench-secret-0123456789abcdef",  # a webhook is signed: no secret, no POST
    )  # fmt: skip
    area = Fence.objects.create(
        name="bench area", inclusion=True, radius_m=5000,
        geometry={"type": "Point", "coordinates": [150.0, -30.0]},
    )  # fmt: skip
    boat = Vessel.objects.create(slug="latency", name="Latency", telemetry_period_s=10)
    AlertRule.objects.update(active=False)  # the fleet stopped reporting: no overdue flood
    rule = AlertRule.objects.create(name="latency", kind="fence", fence=area, vessel=boat)
    rule.channels.add(hook)
    proc = _run_alerts(env)
    rng, figures = random.Random(3), []
    try:
        time.sleep(3)
        for _ in range(trials):
            fix_ingest(vessel=boat, records=[{"time": timezone.now().isoformat(),
                                              "lat": -30.0, "lon": 150.0}])  # fmt: skip
            time.sleep(12 + rng.uniform(0, 10))  # back inside; resolved; a random phase
            earlier = set(Alert.objects.filter(rule=rule).values_list("pk", flat=True))
            posted = time.perf_counter()
            fix_ingest(vessel=boat, records=[{"time": timezone.now().isoformat(),
                                              "lat": -31.0, "lon": 150.0}])  # fmt: skip
            while time.perf_counter() - posted < 30:
                mine = [at for at, pk in arrived if pk not in earlier]
                if sender and mine:
                    figures.append(mine[0] - posted)
                    break
                if not sender and Alert.objects.filter(rule=rule, state="open").exists():
                    figures.append(time.perf_counter() - posted)
                    break
                time.sleep(0.02)
    finally:
        _stop(proc)
        server.shutdown()
    return {"sender": sender, "trials": figures, "asked": trials}


def _run_alerts(env: dict[str, str]) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [sys.executable, "manage.py", "run_alerts", "--skip-checks"],
        cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """SIGTERM, as systemd stops it; a loop that does not stop within 30 s is a finding."""
    proc.terminate()
    try:
        proc.wait(30)
    except subprocess.TimeoutExpired:
        print("bench.alerts: run_alerts did not stop within 30 s of SIGTERM", file=sys.stderr)
        proc.kill()
        proc.wait()


def _timed(fn: Any) -> tuple[float, Any]:
    started = time.perf_counter()
    result = fn()
    return time.perf_counter() - started, result


def child(opts: argparse.Namespace) -> None:
    import django

    django.setup()
    from django.conf import settings
    from django.core.management import call_command
    from django.db import connection

    call_command("migrate", verbosity=0)
    rng = random.Random(19)
    started = time.perf_counter()
    built = build_fleet(rng)
    results: dict[str, Any] = {"db": connection.vendor, "build_s": time.perf_counter() - started}
    results["period_s"] = settings.ALERTS_PERIOD_S
    results.update(timed_passes(built, rng))
    results["reads_s"] = reads_alone(rng, built)
    results["naive_s"] = naive(rng, built)
    env = dict(os.environ)
    results["ingest"] = ingest_rates(built, opts.ingest_s, env)
    if opts.latency:
        results["latency"] = fence_latency(built, env, opts.latency)
    report(results)


def run_child(db: str, opts: argparse.Namespace) -> dict[str, Any]:
    args = ["--ingest-s", str(opts.ingest_s), "--latency", str(opts.latency)]
    # Notifications by e-mail stay in memory: the bench measures the pass, not an SMTP server.
    return run_database_child(
        "bench.alerts", db, args, {"EMAIL_BACKEND": "django.core.mail.backends.locmem.EmailBackend"}
    )


def print_table(r: dict[str, Any]) -> None:
    ms = 1000
    print(f"\n### {r['db']}: {VESSELS:,} vessels, 100 rules (built in {r['build_s']:.1f} s)")
    print(
        f"one pass, {r['fixes']:,} new fixes, quiet: {r['pass_s'] * ms:.0f} ms median, "
        f"{r['pass_max_s'] * ms:.0f} ms max (target <= 1000 ms); "
        f"{r['opened']} opened / {r['resolved']} resolved over {PERIODS} passes"
    )
    print(f"one pass, busy ({r['busy_changes']:.0f} episodes opened or resolved): "
          f"{r['busy_s'] * ms:.0f} ms median, {r['busy_max_s'] * ms:.0f} ms max")  # fmt: skip
    print(
        f"  the first pass (opens the fleet's standing alerts): {r['first_s'] * ms:.0f} ms; "
        f"at an hour's turn (endurance means brought up to date): {r['rollover_s'] * ms:.0f} ms"
    )
    print(
        f"  baseline, the pass's reads alone: {r['reads_s'] * ms:.0f} ms; "
        f"the naive per-rule-per-vessel ORM loop: {r['naive_s'] * ms:,.0f} ms (5 rules, x20)"
    )
    i = r["ingest"]
    change = (i["with"] - i["without"]) / i["without"] * 100
    print(f"ingest, single-fix posts: {i['without']:.0f} fixes/s alone, {i['with']:.0f} fixes/s "
          f"with run_alerts beside it ({change:+.1f} %; medians of {i['windows']} 2-s windows "
          f"each, target within 10 %); run_alerts used "
          f"{i['evaluator_cpu'] * 100:.0f} % of a core judging them (load {i['load']:.1f} on "
          f"{i['cores']} cores)")  # fmt: skip
    lat = r.get("latency")
    if lat and not lat["trials"]:
        print("fence crossing: nothing arrived within 30 s in any trial")
    if lat and lat["trials"]:
        what = "webhook POST arrived" if lat["sender"] else "alert open (no sender yet)"
        t = lat["trials"]
        print(
            f"fence crossing -> {what}, period {r['period_s']:g} s: median "
            f"{statistics.median(t):.2f} s, max {max(t):.2f} s; {len(t)} of {lat['asked']} "
            "trials arrived within 30 s (target <= 5 s)"
        )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m bench.alerts", description=__doc__.split("\n")[0])
    p.add_argument("--postgres", action="store_true", help="also PostgreSQL (127.0.0.1)")
    p.add_argument("--db", choices=["sqlite", "postgres"], help="only this database")
    p.add_argument("--ingest-s", type=float, default=20.0, help="seconds of each ingest kind")
    p.add_argument("--latency", type=int, default=5, help="fence-to-webhook trials (0: none)")
    p.add_argument("--_child", action="store_true", help=argparse.SUPPRESS)
    opts = p.parse_args(argv)
    if opts._child:
        child(opts)
        return 0
    for db in databases(opts.postgres, opts.db):
        print(f"- {db}: building the fleet and measuring ...", flush=True)
        print_table(run_child(db, opts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
