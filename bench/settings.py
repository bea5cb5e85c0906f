"""Bench-only settings: production settings plus the baseline routes (bench.urls).

With BENCH_PROFILE_DIR set, every request is profiled with cProfile (bench.baseline.
ProfileMiddleware) and each worker writes its stats there; `python -m bench.server --profile`.
"""

import os

from fleet.settings import *  # noqa: F403
from fleet.settings import MIDDLEWARE

ROOT_URLCONF = "bench.urls"

if os.environ.get("BENCH_PROFILE_DIR"):
    MIDDLEWARE = ["bench.baseline.ProfileMiddleware", *MIDDLEWARE]
