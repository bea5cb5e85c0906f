"""The measured phases: ingest, no-news polls and the mixed run, each adding to the figures."""

from __future__ import annotations

import argparse
import asyncio
import time

from bench.server.client import get_request, http_request, raw_response_head
from bench.server.constants import (
    BACKLOG_FIXES,
    BATCH,
    COMMANDS,
    DRF_COMMANDS,
    DRF_TELEMETRY,
    FIXES_PER_POST,
    HELLO,
    OPERATOR_EVERY_S,
    POLL_EVERY_S,
    POST_EVERY_S,
    SOAK_BOATS,
    TARGET_304_BYTES,
    TARGET_BACKLOG_S,
    TARGET_INGEST_FPS,
    TARGET_POLL_MEDIAN_MS,
    TARGET_POLLS_PS,
    TARGET_SINGLE_PPS,
    TARGET_SOAK_P99_MS,
    TELEMETRY,
)
from bench.server.fixes import Clock, backlog_upload
from bench.server.mixed import soak_async
from bench.server.report import Figures, check_wrk, fmt, percentile
from bench.server.stack import Stack
from bench.server.wrk import WrkResult, wrk


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
