"""How the Fix admin behaves on a big table: `python -m bench.admin_bigtable [--rows N]`.

Fills a throwaway database (SQLite by default, or DATABASE_URL) with N fixes over a few vessels
and times the fix changelist a logged-in operator sees, next to the vessel changelist (a tiny
table) as the in-run baseline.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rows", type=int, default=2_000_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args(argv)
    os.environ.setdefault("SHORESIDE_DATA_DIR", tempfile.mkdtemp(prefix="shoreside-bench-"))
    os.environ.setdefault("DJANGO_SETTINGS_MODULE", "fleet.settings")
    os.environ["ALLOWED_HOSTS"] = "testserver"
    import django

    django.setup()
    from django.contrib.auth.models import User
    from django.core.management import call_command
    from django.db import connection
    from django.test import Client

    from vessels.services import vessel_create

    call_command("migrate", verbosity=0)
    vessels = [vessel_create(slug=f"bench-{i}", name=f"Bench {i}") for i in range(4)]
    started = time.perf_counter()
    per_vessel = args.rows // len(vessels)
    with connection.cursor() as cursor:
        for vessel in vessels:
            if connection.vendor == "sqlite":
                cursor.execute(
                    "WITH RECURSIVE s(i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM s WHERE i < %s)"
                    " INSERT INTO telemetry_fix (vessel_id, recorded_at, received_at, lat, lon,"
                    " readings) SELECT %s, datetime('2026-01-01', '+' || i || ' seconds'),"
                    " datetime('2026-01-01'), -32 + i * 1e-7, 115 + i * 1e-7, '{}' FROM s",
                    [per_vessel - 1, vessel.pk],
                )
            else:
                cursor.execute(
                    "INSERT INTO telemetry_fix (vessel_id, recorded_at, received_at, lat, lon,"
                    " readings) SELECT %s, timestamptz '2026-01-01' + i * interval '1 second',"
                    " timestamptz '2026-01-01', -32 + i * 1e-7, 115 + i * 1e-7, '{}'"
                    " FROM generate_series(0, %s) AS i",
                    [vessel.pk, per_vessel - 1],
                )
        if connection.vendor == "sqlite":
            cursor.execute("ANALYZE")
        else:
            cursor.execute("ANALYZE telemetry_fix")
    print(
        f"{connection.vendor}: {per_vessel * len(vessels):,} fixes loaded in "
        f"{time.perf_counter() - started:.1f} s"
    )
    User.objects.create_superuser("bench", "bench@example.org", "bench")
    client = Client()
    client.force_login(User.objects.get(username="bench"))
    pages = {
        "vessel list (baseline, 4 rows)": "/admin/vessels/vessel/",
        "fix list, newest first": "/admin/telemetry/fix/",
        "fix list, one vessel": f"/admin/telemetry/fix/?vessel={vessels[1].pk}",
        "fix list, page 50": "/admin/telemetry/fix/?p=50",
        "fix list, last 30 days": "/admin/telemetry/fix/?recorded=30d",
        "one vessel's page (recent fixes)": f"/admin/vessels/vessel/{vessels[1].pk}/change/",
    }
    for label, url in pages.items():
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            response = client.get(url)
            times.append((time.perf_counter() - t0) * 1000)
            assert response.status_code == 200, (url, response.status_code)
        print(f"  {label:38s} median {statistics.median(times):7.1f} ms   max {max(times):7.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
