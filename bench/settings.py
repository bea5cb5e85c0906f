"""Bench-only settings: production settings plus the baseline routes (bench.urls).

With BENCH_PROFILE_DIR set, every request is profiled with cProfile (bench.baseline.
ProfileMiddleware) and each worker writes its stats there; `python -m bench.server --profile`.
"""

import os

from fleet.settings import *  # noqa: F403
from fleet.settings import MIDDLEWARE, REST_FRAMEWORK

ROOT_URLCONF = "bench.urls"
# wrk drives single keys far past any boat: the throttles still run (their cost is in every
# figure), with limits no benchmark reaches.
REST_FRAMEWORK = {
    **REST_FRAMEWORK,
    "DEFAULT_THROTTLE_RATES": {"boat": "100000000/min", "operator": "100000000/min"},
}

if os.environ.get("BENCH_PROFILE_DIR"):
    MIDDLEWARE = ["bench.baseline.ProfileMiddleware", *MIDDLEWARE]
