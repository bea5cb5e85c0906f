"""Alert notifications, timed: ``python -m bench.notify [--count N] [--limit N]`` (issue 19).

A throwaway SQLite database in a temporary data dir (or DATABASE_URL) and a local HTTP
receiver answering 204 on a thread. N alerts owe one webhook each; ``notifications_send_due``
passes (``--limit`` rows a pass) run until none is due: the claim UPDATE, the message, the
signature, the POST and the settling UPDATE per notification. Baseline in the same run: the
same N bodies POSTed with bare ``requests.post`` to the same receiver (the I/O floor, with no
database at all). Then the flood case: N notifications for one SMS channel through the HTTP
gateway, sent as summaries (one request a pass). Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

COUNT = 1_000
LIMIT = 100
BASE = dt.datetime(2026, 11, 28, 3, 12, tzinfo=dt.UTC)


class Counting(BaseHTTPRequestHandler):
    posts = 0
    lock = threading.Lock()

    def do_POST(self) -> None:  # noqa: N802 - http.server's name
        self.rfile.read(int(self.headers.get("Content-Length", 0)))
        with Counting.lock:
            Counting.posts += 1
        self.send_response(204)
        self.send_header("Content-Length", "0")
        self.end_headers()

    def log_message(self, *_args: Any) -> None:
        pass


def receiver() -> tuple[ThreadingHTTPServer, str]:
    server = ThreadingHTTPServer(("127.0.0.1", 0), Counting)
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/hook"


def owe(count: int, channel: Any) -> list[Any]:
    """``count`` open alerts on as many vessels, each owing ``channel`` one notification."""
    from alerts.models import Alert, AlertRule
    from alerts.services.notifications import notifications_queue
    from vessels.models import Vessel

    rule = AlertRule.objects.create(name=f"Overdue {channel.kind}", kind="overdue", threshold=3)
    rule.channels.set([channel])
    start = Vessel.objects.count()
    vessels = Vessel.objects.bulk_create(
        Vessel(slug=f"boat-{start + i:05d}", name=f"Boat {start + i}") for i in range(count)
    )
    alerts = Alert.objects.bulk_create(
        Alert(rule=rule, vessel=v, kind="overdue", opened_at=BASE, detail="silent 25 min")
        for v in vessels
    )
    for alert in alerts:
        notifications_queue(alert=alert, event="alert.opened", now=BASE)
    return alerts


def drain(limit: int) -> tuple[int, int, float]:
    """(delivered, passes, seconds) of send passes until nothing is due."""
    from alerts.services.notifications import notifications_send_due

    delivered = passes = 0
    start = time.perf_counter()
    while done := notifications_send_due(now=BASE, worker="bench", limit=limit):
        delivered += done
        passes += 1
    return delivered, passes, time.perf_counter() - start


def baseline(url: str, alerts: list[Any]) -> float:
    import requests

    from alerts.notify import messages
    from alerts.notify.webhook import body_of

    bodies = [body_of(messages.payload("alert.opened", a)) for a in alerts]
    start = time.perf_counter()
    for body in bodies:
        requests.post(url, data=body, headers={"Content-Type": "application/json"}, timeout=10)
    return time.perf_counter() - start


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=COUNT)
    parser.add_argument("--limit", type=int, default=LIMIT, help="rows claimed per pass")
    args = parser.parse_args(argv)
    os.environ.setdefault("SHORESIDE_DATA_DIR", tempfile.mkdtemp(prefix="shoreside-bench-ntf-"))
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "fleet.settings")
    import django

    django.setup()
    from django.core.management import call_command
    from django.db import connection
    from django.test.utils import override_settings

    from alerts.services.notifications import notification_channel_create

    call_command("migrate", verbosity=0)
    server, url = receiver()
    n = args.count
    print(f"bench.notify on {connection.vendor}: {n} notifications, {args.limit} claimed a pass;"
          " load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))  # fmt: skip

    hook, _secret = notification_channel_create(name="bench", kind="webhook", target=url, by="b")
    alerts = owe(n, hook)
    before = Counting.posts
    delivered, passes, took = drain(args.limit)
    bare = baseline(url, alerts)
    if Counting.posts - before != 2 * n:
        raise SystemExit(f"the receiver got {Counting.posts - before} posts, not {2 * n}")
    print(f"  webhooks    {delivered} sent in {passes} passes: {took:6.2f} s, "
          f"{1000 * took / n:6.2f} ms each")  # fmt: skip
    print(f"  baseline    {n} bare requests.post:   {bare:6.2f} s, {1000 * bare / n:6.2f} ms each"
          f"  (the database and signing add {1000 * (took - bare) / n:5.2f} ms each)")  # fmt: skip

    phone, _ = notification_channel_create(name="bench", kind="sms", target="+61412345678", by="b")
    owe(n, phone)
    before = Counting.posts
    with override_settings(ALERTS_SMS_GATEWAY_URL=url, ALERTS_SMS_MODEM_URL=""):
        delivered, passes, took = drain(args.limit)
    print(f"  flood (SMS) {delivered} summarised in {Counting.posts - before} texts, {passes} "
          f"passes: {took:6.2f} s, {1000 * took / n:6.2f} ms each")  # fmt: skip
    server.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
