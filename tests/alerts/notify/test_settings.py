"""The notification settings refuse what cannot work, when the site starts (fleet/settings.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
SHOW = "import fleet.settings as s; print(s.EMAIL_PORT, s.ALERTS_NOTIFY_FLOOD, s.EMAIL_TIMEOUT)"


def settings_import(tmp_path: Path, **env: str) -> subprocess.CompletedProcess[str]:
    clean = {k: v for k, v in os.environ.items() if not k.startswith(("EMAIL_", "ALERTS_"))}
    clean.update(SHORESIDE_DATA_DIR=str(tmp_path / "data"), **env)
    return subprocess.run([sys.executable, "-c", SHOW], cwd=ROOT, env=clean, capture_output=True,
                          text=True, timeout=60)  # fmt: skip


def test_the_defaults_import(tmp_path: Path) -> None:
    result = settings_import(tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["25", "3", "20"]


@pytest.mark.parametrize(
    ("env", "says"),
    [({"ALERTS_SMS_MODEM_URL": "/dev/ttyUSB2", "ALERTS_SMS_GATEWAY_URL": "https://sms.test/"},
      "not both"),
     ({"EMAIL_USE_TLS": "1", "EMAIL_USE_SSL": "1"}, "exclusive"),
     ({"EMAIL_USE_TLS": "maybe"}, "is not a boolean"),
     ({"ALERTS_NOTIFY_MAX_ATTEMPTS": "0"}, "ALERTS_NOTIFY_MAX_ATTEMPTS"),
     ({"ALERTS_NOTIFY_FLOOD": "-1"}, "ALERTS_NOTIFY_FLOOD")],
)  # fmt: skip
def test_settings_that_cannot_work_stop_the_start(tmp_path: Path, env: dict, says: str) -> None:
    result = settings_import(tmp_path, **env)
    assert result.returncode != 0
    assert says in result.stderr
