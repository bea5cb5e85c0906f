"""The measured phases: ingest, no-news polls and the mixed run.

Each ``measure_<phase>`` drives its load (wrk, http.client, the asyncio fleet), prints progress
as it goes and returns what it measured; ``report.report_<phase>`` turns that into figures.
"""

from __future__ import annotations

import argparse
import asyncio
import time
from dataclasses import dataclass

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
    SINGLE_SLUGS,
    SOAK_BOATS,
    TELEMETRY,
    single_post_slugs,
)
from bench.server.fixes import Clock, backlog_upload
from bench.server.mixed import Sample, soak_async
from bench.server.stack import Stack
from bench.server.wrk import WrkResult, combine, wrk


@dataclass
class IngestRun:
    connections: int
    # "batch", "drf-batch", "single", "drf-single" (posting fixes) and "hello" (the bare view)
    runs: dict[str, WrkResult]
    warm_ok: dict[str, int]  # fixes answered during each warm-up, by vessel slug
    backlog: tuple[float, int]  # one boat's day of fixes, sequential: (seconds, accepted)
    drf_backlog: tuple[float, int]


@dataclass
class PollRun:
    connections: int
    # One no-news poll's status line and headers, byte for byte (and the bare view's 200).
    head: bytes
    head_drf: bytes
    head_hello: bytes
    # wrk on one connection, then on `connections`.
    one: WrkResult
    one_drf: WrkResult
    one_hello: WrkResult
    many: WrkResult
    many_drf: WrkResult
    many_hello: WrkResult


@dataclass
class SoakRun:
    seconds: float
    began: float  # time.monotonic() at the start
    samples: list[Sample]


def measure_ingest(stack: Stack, opts: argparse.Namespace, clock: Clock) -> IngestRun:
    """Posts of fixes under wrk (batches and single fixes, ours and DRF's), the bare view beside
    them, then one boat uploading a day's backlog sequentially (ours and DRF's)."""
    port, k = stack.port, stack.keys
    dur, warm = opts.phase_seconds, opts.warmup_seconds
    conns = opts.connections
    results: dict[str, WrkResult] = {}
    warm_ok: dict[str, int] = {}
    for name, path, slug, batch in (
        ("batch", TELEMETRY, "ingest-batch", BATCH),
        ("drf-batch", DRF_TELEMETRY, "drf-batch", BATCH),
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
        print(
            f"  {name:<11} {r.rps * batch:>10,.0f} fixes/s  {r.rps:>8,.1f} req/s  "
            f"p50 {r.p50_ms:.1f} ms  p99 {r.p99_ms:.1f} ms  CPU/req server {r.cpu_ms:.2f} ms, "
            f"wrk {r.client_cpu_ms:.2f} ms  bad {r.bad} err {r.errors}"
        )
    single = measure_single(stack, opts, clock)
    results["single"], results["drf-single"] = single.ours, single.drf
    warm_ok.update(single.warm_ok)
    hello = wrk(stack, HELLO, "get.lua", ["200"], seconds=dur, connections=conns)
    results["hello"] = hello
    print(
        f"  bare view   {hello.rps:>10,.0f} req/s  p50 {hello.p50_ms:.2f} ms  "
        f"server CPU {hello.cpu_ms:.2f} ms/req"
    )

    seq, seq_accepted = backlog_upload(port, TELEMETRY, k["backlog"], clock.take(BACKLOG_FIXES))
    drf_seq, drf_accepted = backlog_upload(
        port, DRF_TELEMETRY, k["drf-backlog"], clock.take(BACKLOG_FIXES)
    )
    print(f"  backlog     {seq:.2f} s ({seq_accepted} accepted); DRF {drf_seq:.2f} s")
    return IngestRun(conns, results, warm_ok, (seq, seq_accepted), (drf_seq, drf_accepted))


@dataclass
class SingleRun:
    ours: WrkResult  # the rounds combined
    drf: WrkResult
    ratios: list[float]  # ours / DRF's posts per second, round by round
    warm_ok: dict[str, int]


def single_round_order(rounds: int) -> list[str]:
    """ours, DRF, DRF, ours, ours, DRF…: each side runs first as often as second, so a load
    that comes and goes on a shared machine falls on both."""
    order: list[str] = []
    for r in range(rounds):
        order += ["ours", "drf"] if r % 2 == 0 else ["drf", "ours"]
    return order


def measure_single(stack: Stack, opts: argparse.Namespace, clock: Clock) -> SingleRun:
    """Single-fix posts, ours and DRF's, in interleaved rounds of --phase-seconds each.

    Each wrk connection is a boat of its own (its own vessel and key, one wrk thread per
    connection), on both sides alike: a fleet's boats each post their own fixes, and N
    connections posting for one boat would queue on that boat's rows (its last fix, its
    overview minute), which no fleet does.

    Each round also runs ours as the edge client posts (one exchange per period: the
    X-Commands-ETag it holds, the list unchanged), shown beside the others, not in the
    single/DRF ratio."""
    paths = {"ours": TELEMETRY, "drf": DRF_TELEMETRY, "exchange": TELEMETRY}
    conns = opts.connections
    ours_keys = [stack.keys[slug] for slug in single_post_slugs("ours", conns)]
    etags = ",".join(poll_etag(stack.port, key) for key in ours_keys)

    def run(side: str, seconds: float) -> WrkResult:
        slugs_side = "ours" if side == "exchange" else side
        keys = ",".join(stack.keys[slug] for slug in single_post_slugs(slugs_side, conns))
        args = ["1", str(clock.take(2 * 10**6 * conns)), keys]
        if side == "exchange":
            args.append(etags)
        return wrk(
            stack, paths[side], "ingest.lua", args, seconds=seconds, connections=conns,
            threads=conns,
        )  # fmt: skip

    warm_ok = {SINGLE_SLUGS[side]: run(side, opts.warmup_seconds).ok for side in ("ours", "drf")}
    rounds: dict[str, list[WrkResult]] = {"ours": [], "drf": [], "exchange": []}
    for side in single_round_order(opts.rounds):
        rounds[side].append(run(side, opts.phase_seconds))
        if side == "drf" and len(rounds["drf"]) > len(rounds["exchange"]):
            rounds["exchange"].append(run("exchange", opts.phase_seconds))
    ratios = [
        o.rps / d.rps if d.rps else 0.0 for o, d in zip(rounds["ours"], rounds["drf"], strict=True)
    ]
    ours, drf = combine(rounds["ours"]), combine(rounds["drf"])
    exchange = combine(rounds["exchange"])
    for name, r in (("single", ours), ("drf-single", drf), ("+exchange", exchange)):
        print(
            f"  {name:<11} {r.rps:>10,.1f} posts/s  p50 {r.p50_ms:.1f} ms  p99 {r.p99_ms:.1f} ms  "
            f"CPU/req server {r.cpu_ms:.2f} ms, wrk {r.client_cpu_ms:.2f} ms  "
            f"bad {r.bad} err {r.errors}"
        )
    print(
        f"  single/DRF  {ours.rps / drf.rps if drf.rps else 0:.2f}x over {opts.rounds} "
        f"interleaved rounds (per round: {', '.join(f'{x:.2f}' for x in ratios)}); "
        f"with X-Commands-ETag (+exchange)/DRF {exchange.rps / drf.rps if drf.rps else 0:.2f}x",
        flush=True,
    )
    return SingleRun(ours, drf, ratios, warm_ok)


def poll_etag(port: int, key: str) -> str:
    """The command list's ETag a boat holds after polling once (its list is empty here)."""
    status, headers, _ = http_request(
        port, "GET", COMMANDS, headers={"Authorization": f"Api-Key {key}"}
    )
    if status != 200 or not headers.get("ETag"):
        raise SystemExit(f"poll for an ETag failed: {status}")
    return headers["ETag"]


def measure_poll(stack: Stack, opts: argparse.Namespace) -> PollRun:
    """No-news polls (304 with the ETag): the whole response head, then wrk on one connection
    and on many, each beside DRF's poll and the bare view."""
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
    run = PollRun(
        conns, head, head_drf, head_hello, one, one_drf, one_hello, many, many_drf, many_hello
    )
    for name, r in poll_runs_by_name(run):
        print(
            f"  {name:<12} {r.rps:>8,.0f} req/s  p50 {r.p50_ms:.2f} ms  p99 {r.p99_ms:.2f} ms  "
            f"server CPU {r.cpu_ms:.2f} ms/req"
        )
    return run


def poll_runs_by_name(run: PollRun) -> list[tuple[str, WrkResult]]:
    conns = run.connections
    return [
        ("poll c1", run.one),
        ("DRF poll c1", run.one_drf),
        ("bare c1", run.one_hello),
        (f"poll c{conns}", run.many),
        (f"DRF poll c{conns}", run.many_drf),
        (f"bare c{conns}", run.many_hello),
    ]


def measure_soak(stack: Stack, opts: argparse.Namespace, clock: Clock) -> SoakRun:
    """The mixed run: the whole fleet and an operator at once, every request timed."""
    seconds = opts.soak_seconds
    print(
        f"  mixed run: {SOAK_BOATS} boats, poll every {POLL_EVERY_S:g} s, post "
        f"{FIXES_PER_POST} fixes every {POST_EVERY_S:g} s, operator queues a move_to every "
        f"{OPERATOR_EVERY_S:g} s, for {seconds:g} s ...",
        flush=True,
    )
    began = time.monotonic()
    samples = asyncio.run(soak_async(stack, seconds, clock.take(2 * 10**6)))
    return SoakRun(seconds, began, samples)
