"""``python -m bench.server``: arguments, then each database's run from set-up to table."""

from __future__ import annotations

import argparse
import datetime as dt
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

import bench.server as package
from bench.server.constants import HOST
from bench.server.fixes import Clock
from bench.server.helper import django_helper
from bench.server.phases import measure_ingest, measure_poll, measure_single, measure_soak
from bench.server.report import (
    Figures,
    count_stored,
    print_table,
    report_ingest,
    report_poll,
    report_soak,
    summarize_profile,
)
from bench.server.stack import CLEANUP, ensure_wrk, make_stack, provision, start_server


def _on_sigterm(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def bench_db(db: str, opts: argparse.Namespace) -> None:
    started = time.monotonic()
    stack = make_stack(db, opts.worker_class, opts.threads, opts.profile)
    print(f"\n### {stack.label}: migrating a fresh database ...", flush=True)
    stack.manage("migrate", "--noinput")
    provision(stack, opts.connections)
    start_server(stack)
    print(f"### gunicorn 2 x {stack.worker_class} on {HOST}:{stack.port}", flush=True)
    clock = Clock()
    if opts.single_only:
        print(f"- single-fix posts, load average {os.getloadavg()[0]:.1f}", flush=True)
        measure_single(stack, opts, clock)
        CLEANUP.run()
        return
    figures = Figures()
    print("- ingest", flush=True)
    report_ingest(measure_ingest(stack, opts, clock), figures)
    print("- poll", flush=True)
    report_poll(measure_poll(stack, opts), figures)
    print("- mixed run", flush=True)
    report_soak(measure_soak(stack, opts, clock), figures)
    if stack.stop_server:
        CLEANUP.pop(stack.stop_server)
    count_stored(stack, figures)
    print_table(stack, figures, time.monotonic() - started)
    if opts.profile:
        summarize_profile(Path(stack.env["BENCH_PROFILE_DIR"]))
    CLEANUP.run()


def parse_args(argv: list[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="python -m bench.server", description=(package.__doc__ or "").split("\n")[0]
    )
    p.add_argument("--db", choices=["sqlite", "postgres", "both"], default="both")
    p.add_argument("--quick", action="store_true", help="short phases and a 20 s mixed run")
    p.add_argument("--soak-seconds", type=float, help="mixed-run length (default 300, quick 20)")
    p.add_argument("--phase-seconds", type=float, help="each wrk phase (default 20, quick 3)")
    p.add_argument(
        "--rounds", type=int, default=3, help="interleaved rounds of single posts (ours, DRF)"
    )
    p.add_argument(
        "--single-only",
        action="store_true",
        help="only the interleaved single-post rounds (with --quick: about a minute per database)",
    )
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
    if not 1 <= opts.rounds <= 50:
        p.error("--rounds must be between 1 and 50")
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
