"""The database-backed command source in the Level 2 reply path: `python -m bench.bridge`.

Fills a throwaway database (SQLite by default, or DATABASE_URL) with a glider's command history
(``--history`` finished commands, two queued) and times, per call:

* ``pending_count()``, asked on every status request (~1/s), next to ``SELECT 1`` through the
  same Django connection as the in-run baseline (the floor of any query);
* a whole status request handled by the bridge's machine, next to the same machine with the
  in-memory command source (the Level 2 library's own);
* a handover (request queued → command marked sent) and its result (ACK → done), the two
  Level 2 requests that write.

Prints the query plan of the pending query too. Asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable


def timed(call: Callable[[], object], repeat: int) -> list[float]:
    for _ in range(min(50, repeat)):
        call()  # warm-up
    samples = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        call()
        samples.append((time.perf_counter() - t0) * 1000)
    return samples


def show(label: str, samples: list[float]) -> None:
    samples = sorted(samples)
    p99 = samples[min(len(samples) - 1, int(len(samples) * 0.99))]
    print(f"  {label:<58} median {statistics.median(samples):7.3f} ms   p99 {p99:7.3f} ms")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--history", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=2_000)
    parser.add_argument("--handovers", type=int, default=100)
    args = parser.parse_args(argv)
    os.environ.setdefault("SHORESIDE_DATA_DIR", tempfile.mkdtemp(prefix="shoreside-bench-"))
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "fleet.settings")
    import django

    django.setup()
    from django.core.management import call_command
    from django.db import connection

    from commands.models import Command
    from commands.services import command_enqueue
    from sms.bridge.commands import DatabaseCommandSource
    from sms.bridge.machine import BridgeMachine
    from sms.level2.bodies import AckNakQueued, StatusRequest
    from sms.level2.codec import CC_MAIN, Address, Frame, MessageType
    from sms.level2.payload import MemoryCommandSource, PayloadMachine
    from sms.sql import waiting_sql
    from vessels.services import vessel_create

    call_command("migrate", verbosity=0)
    glider = vessel_create(slug="bench-glider", name="Bench glider", kind="wave_glider")
    other = vessel_create(slug="bench-other", name="Other glider", kind="wave_glider")
    history = [
        Command(vessel=v, kind="light", params={"state": "ON"}, status="done")
        for v in (glider, other)
        for _ in range(args.history)
    ]
    Command.objects.bulk_create(history, batch_size=2_000)
    with connection.cursor() as cursor:
        cursor.execute("ANALYZE")
    for state in ("ON", "OFF"):
        command_enqueue(vessel=glider, kind="light", params={"state": state})

    source = DatabaseCommandSource(vessel=glider)
    print(f"{connection.vendor}: {2 * args.history:,} finished commands, 2 queued")
    if connection.vendor == "sqlite":
        now = connection.ops.adapt_datetimefield_value(source.clock())
        with connection.cursor() as cursor:
            cursor.execute(
                f"EXPLAIN QUERY PLAN {waiting_sql('COUNT(*)')}", [glider.pk, "queued", now]
            )
            print("  plan:", "; ".join(row[-1] for row in cursor.fetchall()))

    def select_one() -> None:
        with connection.cursor() as cursor:
            cursor.execute("SELECT 1")
            cursor.fetchone()

    show("SELECT 1 (baseline)", timed(select_one, args.repeat))
    show("pending_count()", timed(source.pending_count, args.repeat))

    me = Address(0, 1)
    status = Frame.make(
        MessageType.REQUEST_STATUS, bytes(StatusRequest()), tid=1, dest=me, src=CC_MAIN
    )
    memory = PayloadMachine(source=MemoryCommandSource())
    bridge = BridgeMachine(source=source)
    tids = iter(range(2, 1 << 30))

    def status_request(machine: PayloadMachine) -> Callable[[], object]:
        # a new tid each time: a repeated one would be answered from the retry cache
        return lambda: machine.handle(
            Frame.make(status.msg_type, status.body, tid=next(tids) & 0xFFFF, dest=me, src=CC_MAIN)
        )

    show("status request, in-memory source (baseline)", timed(status_request(memory), args.repeat))
    show("status request, database source", timed(status_request(bridge), args.repeat))

    for i in range(args.handovers):
        # waypoints: a newer navigation command (fhead) would supersede the queued ones
        command_enqueue(
            vessel=glider,
            kind="waypoint",
            params={"index": 1 + i % 254, "lat": -32.0, "lon": 115.5},
        )
    handovers, results = [], []
    for _ in range(args.handovers):
        tid = next(tids) & 0xFFFF
        request = Frame.make(MessageType.REQUEST_QUEUED, b"", tid=tid, dest=me, src=CC_MAIN)
        t0 = time.perf_counter()
        bridge.handle(request)
        handovers.append((time.perf_counter() - t0) * 1000)
        answer = Frame.make(
            MessageType.ACK_NAK_QUEUED,
            bytes(AckNakQueued(0)),
            tid=tid + 1,
            dest=me,
            src=CC_MAIN,
            no_ack=True,
        )
        t0 = time.perf_counter()
        bridge.handle(answer)
        results.append((time.perf_counter() - t0) * 1000)
    show("request queued → handover (marked sent)", handovers)
    show("ACK → done (through acknowledged)", results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
