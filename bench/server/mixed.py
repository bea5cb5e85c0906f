"""The mixed run's load: an asyncio client playing a fleet of boats and an operator at once."""

from __future__ import annotations

import asyncio
import json
import random
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from bench.server.constants import (
    COMMANDS,
    FIXES_PER_POST,
    HOST,
    OPERATOR_EVERY_S,
    POLL_EVERY_S,
    POST_EVERY_S,
    SOAK_BOATS,
    TELEMETRY,
)
from bench.server.fixes import fix_body, iso_times
from bench.server.stack import Stack


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
    """One boat until ``end``: a post of FIXES_PER_POST fixes every POST_EVERY_S and a poll with
    its ETag every POLL_EVERY_S (acking what it gets), both from a random phase."""
    auth = {"Authorization": f"Api-Key {key}"}
    now = time.monotonic()
    next_poll = now + rng.uniform(0, POLL_EVERY_S)
    next_post = now + rng.uniform(0, POST_EVERY_S)
    etag = ""
    posted = 0
    while (wake := min(next_poll, next_post)) < end:
        await asyncio.sleep(max(0.0, wake - time.monotonic()))
        if next_post <= next_poll:
            next_post += POST_EVERY_S
            await post_fixes(port, auth, samples, first + posted * FIXES_PER_POST)
            posted += 1
        else:
            next_poll += POLL_EVERY_S
            etag = await poll_and_ack(port, auth, etag, samples)


async def post_fixes(port: int, auth: dict[str, str], samples: list[Sample], first: int) -> None:
    """Post FIXES_PER_POST fixes at 1 Hz from ``first``; all of them must be accepted."""
    body = fix_body(iso_times(first, FIXES_PER_POST))
    await timed(samples, "post", aio_request(port, "POST", TELEMETRY, auth, body), _post_ok)


async def poll_and_ack(port: int, auth: dict[str, str], etag: str, samples: list[Sample]) -> str:
    """Poll with ``etag`` and ack every command a changed answer holds; the ETag to send next."""
    headers = {**auth, "If-None-Match": etag} if etag else auth
    got = await timed(samples, "poll", aio_request(port, "GET", COMMANDS, headers), _poll_ok)
    if got is None:
        return etag
    status, resp_headers, payload = got
    if status == 304:
        samples.append(Sample("poll-304", 0, True))
        return etag
    for command in json.loads(payload).get("commands", []):
        ack = json.dumps({"status": "done", "detail": "bench"}).encode()
        path = f"{COMMANDS}{command['uid']}/ack/"
        await timed(samples, "ack", aio_request(port, "POST", path, auth, ack), _ack_ok)
    return resp_headers.get("etag", "")


def _poll_ok(status: int, payload: bytes) -> str:
    return "" if status in (200, 304) else f"poll {status} {payload[:100]!r}"


def _post_ok(status: int, payload: bytes) -> str:
    if status != 200:
        return f"post {status} {payload[:100]!r}"
    if json.loads(payload).get("accepted") != FIXES_PER_POST:
        return f"post accepted {payload[:100]!r}"
    return ""


def _ack_ok(status: int, payload: bytes) -> str:
    return "" if status == 200 else f"ack {status} {payload[:100]!r}"


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
