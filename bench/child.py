"""One benchmark database per child process: bench.maps, bench.retention and bench.alerts each
measure SQLite and PostgreSQL in a fresh child with its own data folder (and, for PostgreSQL,
its own database, dropped afterwards); the child prints its figures as one ``@@RESULT`` line
of JSON."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULT = "@@RESULT "
_PG = ["-h", "127.0.0.1", "-U", "postgres"]


def report(results: dict[str, Any]) -> None:
    """The child's last word: its figures, for :func:`run_child`."""
    print(RESULT + json.dumps(results), flush=True)


def run_child(
    module: str, db: str, args: list[str], env_extra: dict[str, str] | None = None
) -> dict[str, Any]:
    """Run ``python -m <module> --_child <args>`` on ``db`` ("sqlite" or "postgres") and return
    what it reported; exits with the child's output when it reported nothing."""
    short = module.rsplit(".", 1)[-1]
    workdir = Path(tempfile.mkdtemp(prefix=f"shoreside-{short}-{db}-"))
    env = {k: v for k, v in os.environ.items() if k != "DATABASE_URL"}
    env.update(
        DJANGO_SETTINGS_MODULE="bench.settings",
        SHORESIDE_DATA_DIR=str(workdir),
        ALLOWED_HOSTS="testserver",
        DEBUG="0",
        PRODUCTION="0",
        LOG_LEVEL="WARNING",
        **(env_extra or {}),
    )
    name = f"shoreside_{short}_{os.getpid()}"
    if db == "postgres":
        url = os.environ.get("DATABASE_URL", "postgres://postgres@127.0.0.1:5432/x")
        host = url.split("@", 1)[1].split("/", 1)[0]
        subprocess.run(["createdb", *_PG, name], check=True, capture_output=True)
        env["DATABASE_URL"] = f"postgres://postgres@{host}/{name}"
    argv = [sys.executable, "-m", module, "--_child", *args]
    try:
        out = subprocess.run(argv, env=env, cwd=ROOT, capture_output=True, text=True, check=False)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
        if db == "postgres":
            subprocess.run(["dropdb", *_PG, "--if-exists", "--force", name], capture_output=True)
    for line in out.stdout.splitlines():
        if line.startswith(RESULT):
            return json.loads(line.removeprefix(RESULT))
    sys.exit(f"{module} ({db}) failed:\n{out.stdout[-3000:]}\n{out.stderr[-5000:]}")


def databases(postgres: bool, only: str | None) -> list[str]:
    """Which databases a run measures: SQLite, PostgreSQL too with ``--postgres`` or a
    DATABASE_URL, or just ``--db``'s."""
    if only:
        return [only]
    return ["sqlite"] + (["postgres"] if postgres or os.environ.get("DATABASE_URL") else [])
