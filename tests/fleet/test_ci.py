"""CI (``.ci/run``) measures coverage with the project's settings and prints the total."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def sqlite_test_command() -> list[str]:
    """The arguments ``.ci/run`` gives scripts/test.sh on its SQLite run (no DATABASE_URL)."""
    for line in (ROOT / ".ci" / "run").read_text().splitlines():
        words = shlex.split(line, comments=True)
        if words[:2] == ["bash", "scripts/test.sh"]:
            return words[2:]
    raise AssertionError(".ci/run runs no scripts/test.sh on SQLite")


@pytest.mark.slow  # a pytest of its own under coverage: a few seconds
def test_ci_measures_coverage_and_prints_the_total(tmp_path: Path) -> None:
    ci = (ROOT / ".ci" / "run").read_text()
    assert "coverage report --format=total" in ci
    args = sqlite_test_command()
    assert "--cov" in args
    # The same arguments on one small, pure test module: a data file and a total come out.
    env = {**os.environ, "COVERAGE_FILE": str(tmp_path / ".coverage")}
    run = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *args]
    subprocess.run([*run, "tests/sms/level2/test_codec.py"], cwd=ROOT, env=env, check=True,
                   capture_output=True)  # fmt: skip
    total = subprocess.run(
        [sys.executable, "-m", "coverage", "report", "--format=total"],
        cwd=ROOT, env=env, check=True, capture_output=True, text=True,
    ).stdout  # fmt: skip
    assert re.fullmatch(r"\d+\n", total) and 0 < int(total) < 100
