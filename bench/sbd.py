"""The Iridium SBD webhook, timed server-side: ``python -m bench.sbd [--count N]`` (issue 20 §3).

RockBLOCK waits 5 s for an answer; the target is ≤ 50 ms of server time. A throwaway SQLite
database in a temporary data dir (or DATABASE_URL: a fresh one), a provider key pair made here,
a vessel with an IMEI; then N deliveries posted through Django's test client (the whole
request path: middleware, the form, RS256 verification, the compact decode, the message row and
the fix ingest), each timed alone:

* ``fixes``: a 340-byte-class message of 20 compact fixes (a boat's half hour);
* ``position``: an empty payload (the Iridium position kept as a fix);
* ``retry``: the provider posting the first kind again (counted once, nothing stored).

Beside them, the JWT check alone (the RSA verify) for scale. Prints median and p99 in ms;
asserts nothing.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from typing import Any

COUNT = 200
IMEI = "300434063839690"


def percentile(values: list[float], p: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(p / 100 * (len(ordered) - 1)))]


def report(name: str, times_s: list[float]) -> None:
    ms = [t * 1000 for t in times_s]
    print(
        f"{name:<9} n={len(ms):<4} median {statistics.median(ms):6.2f} ms"
        f"   p99 {percentile(ms, 99):6.2f} ms   max {max(ms):6.2f} ms"
    )


def timed(calls: Sequence[Callable[[], Any]]) -> list[float]:
    out = []
    for call in calls:
        start = time.perf_counter()
        call()
        out.append(time.perf_counter() - start)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=COUNT, help="posts of each kind")
    args = parser.parse_args(argv)
    os.environ.setdefault("SHORESIDE_DATA_DIR", tempfile.mkdtemp(prefix="shoreside-bench-sbd-"))
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "fleet.settings")
    import django

    django.setup()
    import jwt
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import rsa
    from django.core.management import call_command
    from django.db import connection
    from django.test import Client
    from django.test.utils import override_settings

    from edge_client.contract import compact
    from sbd import signing
    from vessels.services import vessel_create

    call_command("migrate", verbosity=0)
    key = rsa.generate_private_key(public_exponent=65537, key_size=2048)
    key_file = os.path.join(os.environ["SHORESIDE_DATA_DIR"], "rockblock.pem")
    with open(key_file, "wb") as handle:
        handle.write(
            key.public_key().public_bytes(
                serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo
            )
        )
    vessel_create(slug="sat", name="Sat", imei=IMEI, telemetry_period_s=90)
    start = dt.datetime.now(dt.UTC).replace(microsecond=0) - dt.timedelta(days=30)
    momsn = 0

    def delivery(payload: bytes, sent: dt.datetime) -> dict[str, str]:
        nonlocal momsn
        momsn += 1
        form = {
            "imei": IMEI,
            "momsn": str(momsn % 65536),
            "transmit_time": sent.strftime("%y-%m-%d %H:%M:%S"),
            "iridium_latitude": "-32.0512",
            "iridium_longitude": "115.7421",
            "iridium_cep": "3.0",
            "data": payload.hex(),
        }
        return {**form, "JWT": jwt.encode({**form, "iss": "Rock 7"}, key, algorithm="RS256")}

    def fixes(at: dt.datetime) -> bytes:
        return compact.encode(
            [
                {
                    "time": (at + dt.timedelta(seconds=90 * i)).isoformat(),
                    "lat": -32.05 + i * 1e-4,
                    "lon": 115.74 + i * 1.3e-4,
                    "heading_deg": 52,
                    "speed_mps": 1.4,
                    "battery_v": 12.6 - i * 0.01,
                }
                for i in range(20)
            ]
        )

    n = args.count
    with_fixes = [delivery(fixes(start + dt.timedelta(hours=i)), start) for i in range(n)]
    position = [delivery(b"", start + dt.timedelta(hours=i, minutes=30)) for i in range(n)]
    sizes = {len(bytes.fromhex(d["data"])) for d in with_fixes}
    client = Client()
    url = "/api/v1/sbd/rockblock/"
    with override_settings(ALLOWED_HOSTS=["testserver"], SBD_ROCKBLOCK_PUBLIC_KEY_FILE=key_file):
        client.post(url, delivery(b"", start - dt.timedelta(days=1)))  # warm: key, connection
        answers: list[int] = []

        def post(form: dict[str, str]) -> Callable[[], None]:
            return lambda: answers.append(client.post(url, form).status_code)

        print(f"SBD webhook, {n} posts of each kind, {connection.vendor}, 20 fixes in", end=" ")
        print(f"{min(sizes)}-{max(sizes)} bytes")
        report("fixes", timed([post(f) for f in with_fixes]))
        report("position", timed([post(f) for f in position]))
        report("retry", timed([post(f) for f in with_fixes]))
        public = signing.public_key(key_file)
        report("jwt only", timed([lambda f=f: signing.verify(f, public) for f in with_fixes]))
    bad = [a for a in answers if a != 200]
    if bad:
        print(f"unexpected answers: {sorted(set(bad))}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
