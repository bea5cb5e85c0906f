"""Fix load: request bodies of fixes, disjoint fix times, one boat's sequential backlog upload."""

from __future__ import annotations

import datetime as dt
import http.client
import json
import time

from bench.server.constants import BACKLOG_FIXES, BATCH, HOST


class Clock:
    """Hands out disjoint ranges of past fix times, so no two phases ever share a timestamp."""

    def __init__(self) -> None:
        self.next = 1_546_300_800  # 2019-01-01: plausible, and ~2.5e8 s before today

    def take(self, seconds: int) -> int:
        first = self.next
        self.next += seconds + 3600
        return first


def iso_times(first: int, count: int) -> list[str]:
    base = dt.datetime.fromtimestamp(first, dt.UTC)
    return [(base + dt.timedelta(seconds=i)).isoformat() for i in range(count)]


def fix_body(times: list[str]) -> bytes:
    fixes = [
        {
            "time": t,
            "lat": -32.05 + (i % 1000) * 1e-5,
            "lon": 115.74 + (i % 777) * 1e-5,
            "heading_deg": (i * 7) % 360,
            "speed_mps": 1.5,
            "battery_v": 12.6,
            "readings": {"water_temp_c": 18.2, "salinity_psu": 35.1},
        }
        for i, t in enumerate(times)
    ]
    return json.dumps({"fixes": fixes}).encode()


def backlog_upload(port: int, path: str, key: str, first: int) -> tuple[float, int]:
    """One boat uploads a day of 1 Hz fixes in batches of 500, sequentially; (seconds, accepted).

    Bodies are encoded before the clock starts; one keep-alive connection where the server
    allows it (http.client reconnects when the server closes)."""
    times = iso_times(first, BACKLOG_FIXES)
    bodies = [fix_body(times[i : i + BATCH]) for i in range(0, BACKLOG_FIXES, BATCH)]
    headers = {"Authorization": f"Api-Key {key}", "Content-Type": "application/json"}
    conn = http.client.HTTPConnection(HOST, port, timeout=60)
    accepted = 0
    start = time.perf_counter()
    try:
        for body in bodies:
            conn.request("POST", path, body=body, headers=headers)
            response = conn.getresponse()
            payload = response.read()
            if response.status == 200:
                accepted += json.loads(payload).get("accepted", 0)
            if response.will_close:
                conn.close()
    finally:
        conn.close()
    return time.perf_counter() - start, accepted
