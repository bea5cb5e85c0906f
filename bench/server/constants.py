"""What bench.server measures against: issue 2's targets, the load's shape and the URLs it hits."""

from __future__ import annotations

HOST = "127.0.0.1"  # the only address the benchmark ever contacts

# The targets of issue 2 ("Speed").
TARGET_INGEST_FPS = 25_000
TARGET_BACKLOG_S = 4.0
TARGET_SINGLE_PPS = 1_000
TARGET_304_BYTES = 200
TARGET_POLL_MEDIAN_MS = 2.0
TARGET_POLLS_PS = 1_000
TARGET_SOAK_P99_MS = 100.0

BACKLOG_FIXES = 86_400
BATCH = 500
SOAK_BOATS = 200
POLL_EVERY_S = 5.0
POST_EVERY_S = 10.0
FIXES_PER_POST = 10  # 10 s of 1 Hz fixes per post
OPERATOR_EVERY_S = 2.0

# Single-fix posts: each wrk connection posts as a boat of its own (slug-0, slug-1, …), ours
# and DRF's alike, as a fleet does: one boat per connection, not N connections for one boat.
SINGLE_SLUGS = {"ours": "ingest-single", "drf": "drf-single"}


def single_post_slugs(side: str, connections: int) -> list[str]:
    """The vessels one side's single-fix posts use: one per wrk connection."""
    return [f"{SINGLE_SLUGS[side]}-{i}" for i in range(connections)]


TELEMETRY = "/api/v1/boat/telemetry/"
COMMANDS = "/api/v1/boat/commands/"
HELLO = "/bench/hello/"
DRF_TELEMETRY = "/bench/drf/telemetry/"
DRF_COMMANDS = "/bench/drf/commands/"
