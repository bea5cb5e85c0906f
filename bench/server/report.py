"""Reporting: the figures table (each figure beside its baselines and target), notes, profiles."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from bench.server.constants import (
    BACKLOG_FIXES,
    BATCH,
    FIXES_PER_POST,
    POLL_EVERY_S,
    SINGLE_SLUGS,
    SOAK_BOATS,
    TARGET_304_BYTES,
    TARGET_BACKLOG_S,
    TARGET_INGEST_FPS,
    TARGET_POLL_MEDIAN_MS,
    TARGET_POLLS_PS,
    TARGET_SINGLE_PPS,
    TARGET_SOAK_P99_MS,
)
from bench.server.phases import IngestRun, PollRun, SoakRun, poll_runs_by_name
from bench.server.stack import Stack
from bench.server.wrk import WrkResult


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


def percentile(values: list[float], q: float) -> float:
    if not values:
        return 0.0
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def count_stored(stack: Stack, figures: Figures) -> None:
    counts = stack.helper("count")
    for base in SINGLE_SLUGS.values():  # one vessel per connection: count them as one
        counts[base] = sum(n for slug, n in counts.items() if slug.startswith(f"{base}-"))
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
    title = f"{stack.label}, {server}, wrk on the same 2 cores"
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


def report_ingest(run: IngestRun, figures: Figures) -> None:
    """Ingest figures: fixes/s in batches, the backlog's time, single posts/s, CPU per fix."""
    conns = run.connections
    results = run.runs
    for name in ("batch", "drf-batch", "single", "drf-single"):
        check_wrk(f"ingest {name}", results[name], figures)
    hello = results["hello"]
    check_wrk("bare view", hello, figures)
    seq, seq_accepted = run.backlog
    drf_seq, drf_accepted = run.drf_backlog
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
        f"single-fix posts/s (wrk -c{conns}, a boat each)",
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
            "ingest-batch": b.ok * BATCH + run.warm_ok["ingest-batch"],
            "ingest-single": s.ok + run.warm_ok["ingest-single"],
            "drf-batch": db_.ok * BATCH + run.warm_ok["drf-batch"],
            "drf-single": ds.ok + run.warm_ok["drf-single"],
            "backlog": seq_accepted,
            "drf-backlog": drf_accepted,
        }
    )


def report_poll(run: PollRun, figures: Figures) -> None:
    """Poll figures: the 304's size, its latency on one connection, polls/s, CPU per poll."""
    if not run.head.startswith(b"HTTP/1.1 304"):
        figures.notes.append(f"no-news poll did not answer 304: {run.head[:60]!r}")
    for name, r in poll_runs_by_name(run):
        check_wrk(name, r, figures)
    conns = run.connections
    figures.row(
        "no-news poll: 304 status line + headers (bytes)",
        str(len(run.head)),
        str(len(run.head_drf)),
        f"{len(run.head_hello)} (200)",
        f"<= {TARGET_304_BYTES}",
        len(run.head) <= TARGET_304_BYTES and run.head.startswith(b"HTTP/1.1 304"),
    )
    figures.row(
        "no-news poll, 1 conn: median (ms)",
        f"{run.one.p50_ms:.2f}",
        f"{run.one_drf.p50_ms:.2f}",
        f"{run.one_hello.p50_ms:.2f}",
        f"<= {TARGET_POLL_MEDIAN_MS:g}",
        run.one.p50_ms <= TARGET_POLL_MEDIAN_MS,
    )
    figures.row(
        "no-news poll, 1 conn: p99 (ms)",
        f"{run.one.p99_ms:.2f}",
        f"{run.one_drf.p99_ms:.2f}",
        f"{run.one_hello.p99_ms:.2f}",
    )
    figures.row(
        f"no-news polls/s (wrk -c{conns})",
        fmt(run.many.rps),
        fmt(run.many_drf.rps),
        f"{fmt(run.many_hello.rps)} GET/s",
        f">= {TARGET_POLLS_PS:,}",
        run.many.rps >= TARGET_POLLS_PS,
    )
    figures.row(
        "  server CPU per poll (ms)",
        fmt(run.many.cpu_ms, 2),
        fmt(run.many_drf.cpu_ms, 2),
        f"{fmt(run.many_hello.cpu_ms, 2)} (200)",
    )


def report_soak(run: SoakRun, figures: Figures) -> None:
    """Mixed-run figures: requests, errors and latency percentiles, overall and per kind."""
    seconds, began, samples = run.seconds, run.began, run.samples
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
