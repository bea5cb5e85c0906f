"""The boat's install: the project with its `[edge]` extra alone, in a virtualenv of its own.

What the Pi gets (docs/edge-client.md, "Install on a Pi"): pip installs this checkout with
`[edge]`, from PyPI through pip's cache, and nothing of the server comes with it. The edge
client from that virtualenv then drives the simulator against the live server for a few
seconds; its fixes must arrive, and it must have loaded no server package on the way.
About 40 s (2 cores, load 4), nearly all of it pip; CI runs it once, on SQLite (.ci/run).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest

from telemetry.models import Fix
from tests.edge_client.conftest import free_port
from tests.edge_client.helpers import ROOT, wait_until
from tests.fleet.test_layers import SERVER_PACKAGES
from vessels.services import vessel_create, vessel_key_issue

pytestmark = [pytest.mark.django_db(transaction=True), pytest.mark.slow]

INSTALL_TIMEOUT_S = 600  # a cold pip cache downloads pymavlink and lxml
# Runs the client as `python -m edge_client` does, then writes which server packages it loaded.
RUN_AND_REPORT = """
import atexit, runpy, sys
server = set(sys.argv.pop(1).split(","))
report = sys.argv.pop(1)
def write() -> None:
    loaded = {name.split(".")[0] for name in sys.modules} & server
    with open(report, "w") as f:
        f.write(" ".join(sorted(loaded)) or "none")
atexit.register(write)
sys.argv[0] = "edge_client"
runpy.run_module("edge_client", run_name="__main__", alter_sys=True)
"""


def checkout_copy(dest: Path) -> Path:
    """What a clone holds for the build (pyproject's packages), without .venv, caches or .git:
    an install from the worktree itself would leave build/ and egg-info in it."""
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    patterns = pyproject["tool"]["setuptools"]["packages"]["find"]["include"]
    dest.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, dest / name)
    for pattern in patterns:
        for package in ROOT.glob(pattern):
            if package.is_dir() and (package / "__init__.py").exists():
                shutil.copytree(package, dest / package.name,
                                ignore=shutil.ignore_patterns("__pycache__"))  # fmt: skip
    return dest


def clean_env() -> dict[str, str]:
    """This test run's environment without its own virtualenv or source tree on the path."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.pop("NOTIFY_SOCKET", None)
    return {**env, "PYTHONUNBUFFERED": "1", "PIP_DISABLE_PIP_VERSION_CHECK": "1"}


@pytest.fixture(scope="module")
def edge_venv(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A fresh virtualenv holding `shoreside[edge]`, installed from a copy of this checkout."""
    base = tmp_path_factory.mktemp("edge-extra")
    source = checkout_copy(base / "src")
    venv = base / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    install = subprocess.run(
        [str(venv / "bin/python"), "-m", "pip", "install", "--quiet", f"{source}[edge]"],
        cwd=base, env=clean_env(), capture_output=True, text=True, timeout=INSTALL_TIMEOUT_S,
    )  # fmt: skip
    assert install.returncode == 0, install.stdout + install.stderr
    yield venv
    shutil.rmtree(base, ignore_errors=True)  # ~145 MB (lxml comes with pymavlink)


def run_in(venv: Path, *args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(venv / "bin/python"), *args], cwd=cwd, env=clean_env(),
                          capture_output=True, text=True, timeout=60)  # fmt: skip


def test_the_edge_extra_brings_no_server_dependency(edge_venv: Path, tmp_path: Path) -> None:
    help_ = run_in(edge_venv, "-m", "edge_client", "--help", cwd=tmp_path)
    assert help_.returncode == 0, help_.stderr
    assert "run" in help_.stdout and "check" in help_.stdout
    for package in ("django", "rest_framework", "psycopg", "phonenumbers", "gunicorn"):
        found = run_in(edge_venv, "-c", f"import {package}", cwd=tmp_path)
        assert found.returncode == 1 and "ModuleNotFoundError" in found.stderr, package
    # It is the installed copy that ran, not this checkout.
    where = run_in(edge_venv, "-c", "import edge_client; print(edge_client.__file__)", cwd=tmp_path)
    assert where.stdout.startswith(str(edge_venv)), where.stdout


def test_the_edge_extra_alone_runs_a_boat(edge_venv: Path, tmp_path: Path, live_server) -> None:
    vessel = vessel_create(slug="spab", name="SPAB", kind="mavlink")
    _, key = vessel_key_issue(vessel=vessel, label="edge extra test")
    port, report = free_port(), tmp_path / "loaded.txt"
    python, env = str(edge_venv / "bin/python"), {**clean_env(), "SHORESIDE_EDGE_KEY": key}
    with open(tmp_path / "sim.log", "wb") as sim_log, open(tmp_path / "edge.log", "wb") as log:
        sim = subprocess.Popen(
            [python, "-m", "edge_client.sim", "--listen", f"udpin:127.0.0.1:{port}",
             "--rate", "10", "--prearm-delay", "1", "--position-delay", "0.5"],
            cwd=tmp_path, env=env, stdout=sim_log, stderr=subprocess.STDOUT,
        )  # fmt: skip
        edge = subprocess.Popen(
            [python, "-c", RUN_AND_REPORT, ",".join(sorted(SERVER_PACKAGES)), str(report),
             "run", "--server", live_server.url, "--mavlink", f"udpout:127.0.0.1:{port}",
             "--outbox", str(tmp_path / "outbox.sqlite3"),
             "--telemetry-period", "0.3", "--poll-period", "0.3"],
            cwd=tmp_path, env=env, stdout=log, stderr=subprocess.STDOUT,
        )  # fmt: skip
        try:
            wait_until(lambda: Fix.objects.filter(vessel=vessel).count() >= 3, 30, "fixes")
        finally:
            edge.send_signal(signal.SIGTERM)
            status = edge.wait(30)
            sim.terminate()
            sim.wait(10)
    assert status == 0, (tmp_path / "edge.log").read_text()
    assert report.read_text() == "none"
