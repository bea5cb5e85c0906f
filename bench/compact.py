"""Compact fix encoding benchmark (issue 20 §2): speed and size, each next to JSON in the same run.

Run: ``python -m bench.compact`` (prints figures; asserts nothing).

* Speed: encode and decode a batch of 10,000 fixes (a boat on a wandering course, GPS noise,
  battery and two sensors) with edge_client/contract/compact.py, against ``json.dumps`` /
  ``json.loads`` of the same fixes in the API's shape (C-accelerated: the floor any pure-Python
  codec is compared with). Best of several runs. Target: ≥ 100,000 fixes/s each way.
* Size: bytes per fix of a batch of 60 (what one Iridium SBD message must hold: ≤ 340 bytes)
  and of one fix alone, for a SPAB boat (every 10 s, with readings), the same boat without
  readings, and a Wave Glider (every 10 minutes), against the same fixes as compact JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import random
import time
from collections.abc import Callable, Sequence
from typing import Any

from edge_client.contract.compact import CRC_BYTES, HEADER, Channel, decode, encode

T0 = 1_790_000_000
CHANNELS = [Channel("humidity_pct", 0.1), Channel("water_temp_c", 0.01)]
SBD_BYTES = 340
SPEED_TARGET = 100_000


def track(n: int, *, period_s: int, speed_mps: float, readings: bool, seed: int = 7) -> list[dict]:
    """A vessel wandering at about ``speed_mps``, 1.5 m of GPS noise, battery and sensors
    drifting; fixes in the API's shape."""
    rng = random.Random(seed)
    lat, lon, heading, volts, humidity, water = -32.05, 115.74, 80.0, 12.6, 41.0, 18.4
    fixes = []
    for i in range(n):
        heading = (heading + rng.gauss(0, 4)) % 360
        speed = max(0.0, speed_mps + rng.gauss(0, 0.1))
        metres = speed * period_s
        lat += (metres * math.cos(math.radians(heading)) + rng.gauss(0, 1.5)) / 111_320
        lon += metres * math.sin(math.radians(heading)) / (111_320 * math.cos(math.radians(lat)))
        volts = volts - rng.choice((0, 0, 0, 0.01)) if volts > 11.0 else 12.8  # a day's charge
        humidity += rng.gauss(0, 0.2)
        water += rng.gauss(0, 0.02)
        fix: dict[str, Any] = {
            "time": T0 + period_s * i, "lat": round(lat, 6), "lon": round(lon, 6),
            "heading_deg": round(heading, 1), "speed_mps": round(speed, 2),
            "battery_v": round(volts, 2),
        }  # fmt: skip
        if readings:
            fix["readings"] = {"humidity_pct": round(humidity, 1), "water_temp_c": round(water, 2)}
        fixes.append(fix)
    return fixes


def best_rate(fn: Callable[[], Any], count: int, repeat: int = 5) -> float:
    best = math.inf
    for _ in range(repeat):
        started = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - started)
    return count / best


def speed(n: int) -> list[tuple[str, float, float]]:
    fixes = track(n, period_s=10, speed_mps=2.0, readings=True)
    payload = encode(fixes, CHANNELS)
    text = json.dumps({"fixes": fixes}, separators=(",", ":"))
    return [
        ("encode", best_rate(lambda: encode(fixes, CHANNELS), n),
         best_rate(lambda: json.dumps({"fixes": fixes}, separators=(",", ":")), n)),
        ("decode", best_rate(lambda: decode(payload, CHANNELS), n),
         best_rate(lambda: json.loads(text), n)),
    ]  # fmt: skip


def sizes() -> list[tuple[str, int, float, float, int]]:
    """(vessel, fixes in 340 bytes, compact bytes a fix, JSON bytes a fix, one fix alone)."""
    rows = []
    for label, period_s, speed_mps, readings in (
        ("SPAB boat, every 10 s, 2 readings", 10, 2.0, True),
        ("SPAB boat, every 10 s, no readings", 10, 2.0, False),
        ("Wave Glider, every 10 min, 2 readings", 600, 0.7, True),
    ):
        fixes = track(200, period_s=period_s, speed_mps=speed_mps, readings=readings)
        fit = max(n for n in range(1, len(fixes)) if len(encode(fixes[:n], CHANNELS)) <= SBD_BYTES)
        sixty = fixes[:60]
        compact = len(encode(sixty, CHANNELS)) / 60
        text = len(json.dumps({"fixes": sixty}, separators=(",", ":"))) / 60
        alone = len(encode(fixes[:1], CHANNELS))
        rows.append((label, fit, compact, text, alone))
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--fixes", type=int, default=10_000, help="fixes in the speed batch")
    args = parser.parse_args(argv)
    print(f"Compact fixes: speed, a batch of {args.fixes:,} (best of 5)")
    for label, ours, base in speed(args.fixes):
        print(f"  {label}: {ours:>10,.0f} fixes/s   baseline JSON (C): {base:>11,.0f} fixes/s"
              f"   (target >= {SPEED_TARGET:,})")  # fmt: skip
    overhead = HEADER.size + CRC_BYTES
    print(f"Compact fixes: size (a payload has {overhead} bytes of header and checksum)")
    for label, fit, compact, text, alone in sizes():
        print(f"  {label}: {fit} fixes in one {SBD_BYTES}-byte SBD message (target >= 60); "
              f"{compact:.1f} bytes a fix in a batch of 60 against {text:.0f} as JSON "
              f"({compact / text:.1%}); one fix alone {alone} bytes")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
