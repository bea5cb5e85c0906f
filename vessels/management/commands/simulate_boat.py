"""Play a boat over real HTTP against a running Shoreside server, with a vessel key.

Reports fixes along a patrol route, polls for commands with ETag, executes move_to / hold /
mission / … by changing its simulated course, and acks. Run several at once for a fleet.
"""

from __future__ import annotations

import datetime as dt
import json
import random
import signal
import time
from collections import deque
from typing import Any

import requests
from django.core.management.base import BaseCommand, CommandError, CommandParser

from vessels.simulation import SimBoat, patrol_route

MAX_BACKLOG = 10_000


class Command(BaseCommand):
    help = "Simulate a boat reporting to a Shoreside server over HTTP."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--server", default="http://127.0.0.1:8000")
        parser.add_argument("--key", help="vessel key (or --key-file)")
        parser.add_argument("--key-file", help="file holding the vessel key")
        parser.add_argument(
            "--start",
            default="-31.9790,115.8170",
            help="lat,lon to start at (default: Matilda Bay)",
        )
        parser.add_argument("--speed", type=float, default=2.0, help="m/s")
        parser.add_argument("--sample", type=float, default=2.0, help="seconds between fixes")
        parser.add_argument("--period", type=float, default=10.0, help="seconds between posts")
        parser.add_argument("--poll", type=float, default=5.0, help="seconds between polls")
        parser.add_argument(
            "--speedup", type=float, default=1.0, help="simulated seconds per real second"
        )
        parser.add_argument(
            "--duration",
            type=float,
            default=0.0,
            help="stop after this many seconds (0 = until stopped)",
        )
        parser.add_argument("--seed", type=int, default=1)

    def handle(self, *args: Any, **opts: Any) -> None:
        key = opts["key"] or (open(opts["key_file"]).read().strip() if opts["key_file"] else "")
        if not key:
            raise CommandError("give --key or --key-file")
        try:
            lat, lon = (float(v) for v in opts["start"].split(","))
        except ValueError:
            raise CommandError("--start must be lat,lon") from None
        self.boat = SimBoat(
            lat=lat,
            lon=lon,
            speed_mps=opts["speed"],
            route=patrol_route(lat, lon),
            rng=random.Random(opts["seed"]),
        )
        self.server = opts["server"].rstrip("/")
        self.http = requests.Session()
        self.http.headers["Authorization"] = f"Api-Key {key}"
        self.backlog: deque[dict[str, Any]] = deque(maxlen=MAX_BACKLOG)
        self.etag: str | None = None
        self.seen: set[str] = set()
        self.active: dict[str, tuple[str, dict[str, Any]]] = {}
        self.pending_acks: deque[tuple[str, str, str]] = deque()
        self.stopping = False
        previous = {sig: signal.signal(sig, self._stop) for sig in (signal.SIGTERM, signal.SIGINT)}
        try:
            self.run(opts)
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)

    def _stop(self, signum: int, frame: Any) -> None:
        self.stopping = True

    def run(self, opts: dict[str, Any]) -> None:
        start = time.monotonic()
        next_sample = next_post = next_poll = start
        last = start
        while not self.stopping:
            now = time.monotonic()
            if opts["duration"] and now - start >= opts["duration"]:
                break
            self.boat.step((now - last) * opts["speedup"])
            last = now
            if now >= next_sample:
                self.backlog.append(self.boat.fix(dt.datetime.now(dt.UTC)))
                next_sample += opts["sample"]
            if now >= next_post:
                self.do_one_post()
                next_post += opts["period"]
            if now >= next_poll:
                self.do_one_poll()
                self.check_finished()
                self.flush_acks()
                next_poll += opts["poll"]
            time.sleep(0.05)
        self.do_one_post()
        self.stdout.write("simulated boat stopped")

    def _request(self, method: str, path: str, **kwargs: Any) -> requests.Response | None:
        try:
            return self.http.request(method, self.server + path, timeout=10, **kwargs)
        except requests.RequestException as exc:
            self.stderr.write(f"server unreachable ({exc.__class__.__name__}); will retry")
            return None

    def do_one_post(self) -> None:
        """Send the backlog; fixes leave it only once the server has answered for them."""
        if not self.backlog:
            return
        batch = list(self.backlog)[:500]
        response = self._request("POST", "/api/v1/boat/telemetry/", json={"fixes": batch})
        if response is None or response.status_code >= 500:
            return
        if response.status_code != 200:
            self.stderr.write(f"telemetry refused: {response.status_code} {response.text[:200]}")
            # Only a 400 means the batch itself is bad; a refused key (401/403) or a limit
            # (413/429) says nothing against the fixes, so they wait for the next try.
            if response.status_code != 400:
                return
        for _ in batch:
            self.backlog.popleft()
        if response.status_code != 200:
            return
        result = response.json()
        self.stdout.write(
            f"posted {len(batch)} fix(es): accepted {result['accepted']}, "
            f"duplicates {result['duplicates']}, rejected {len(result['rejected'])}"
        )

    def do_one_poll(self) -> None:
        headers = {"If-None-Match": self.etag} if self.etag else {}
        response = self._request("GET", "/api/v1/boat/commands/", headers=headers)
        if response is None or response.status_code == 304:
            return
        if response.status_code != 200:
            self.stderr.write(f"poll refused: {response.status_code} {response.text[:200]}")
            return
        self.etag = response.headers.get("ETag")
        for command in response.json()["commands"]:
            if command["uid"] in self.seen:
                continue  # at-least-once delivery: run each uid once
            self.seen.add(command["uid"])
            status, detail = self.boat.execute(command["kind"], command["params"])
            self.stdout.write(
                f"command {command['kind']} {json.dumps(command['params'])[:80]}"
                f" → {status}: {detail}"
            )
            self.pending_acks.append((command["uid"], status, detail))
            if status == "acknowledged":
                self.active[command["uid"]] = (command["kind"], command["params"])

    def check_finished(self) -> None:
        for uid, (kind, params) in list(self.active.items()):
            if self.boat.finished(kind, params):
                detail = "arrived" if kind != "mission" else "mission complete"
                self.pending_acks.append((uid, "done", detail))
                del self.active[uid]

    def flush_acks(self) -> None:
        """Send queued acks in order; one that cannot reach the server waits for the next try."""
        while self.pending_acks:
            uid, status, detail = self.pending_acks[0]
            response = self._request(
                "POST",
                f"/api/v1/boat/commands/{uid}/ack/",
                json={"status": status, "detail": detail},
            )
            if response is None or response.status_code >= 500:
                return
            if response.status_code != 200:
                self.stderr.write(f"ack refused: {response.status_code} {response.text[:200]}")
            self.pending_acks.popleft()
