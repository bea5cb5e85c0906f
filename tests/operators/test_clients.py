"""The client's address: X-Forwarded-For only from trusted proxies (operators/clients.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from operators.clients import client_address_from

LOCAL = ["127.0.0.1", "::1"]
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("remote", "forwarded", "trusted", "client"),
    [
        # Not from a proxy: the header is whatever the client wrote.
        ("203.0.113.66", "10.0.0.1", LOCAL, "203.0.113.66"),
        ("203.0.113.66", "", LOCAL, "203.0.113.66"),
        ("127.0.0.1", "198.51.100.10", [], "127.0.0.1"),
        # From the proxy: the entry it appended, not the forged ones before it.
        ("127.0.0.1", "198.51.100.10", LOCAL, "198.51.100.10"),
        ("127.0.0.1", "9.9.9.9, 198.51.100.10", LOCAL, "198.51.100.10"),
        ("::1", "2001:db8::7", LOCAL, "2001:db8::7"),
        # A chain of trusted proxies (a load balancer in 10.0.0.0/8, then the local proxy).
        ("127.0.0.1", "6.6.6.6, 198.51.100.10, 10.1.2.3", [*LOCAL, "10.0.0.0/8"], "198.51.100.10"),
        ("127.0.0.1", "6.6.6.6, 198.51.100.10, 10.1.2.3", LOCAL, "10.1.2.3"),
        # The proxy without a header (its own health check): the proxy itself.
        ("127.0.0.1", "", LOCAL, "127.0.0.1"),
    ],
)
def test_client_address(remote: str, forwarded: str, trusted: list[str], client: str) -> None:
    assert client_address_from(remote, forwarded, trusted) == client


def _trusted_proxies(tmp_path: Path, **env: str) -> subprocess.CompletedProcess[str]:
    clean = {
        k: v for k, v in os.environ.items() if k not in {"BEHIND_TLS_PROXY", "TRUSTED_PROXIES"}
    }
    clean.update(SHORESIDE_DATA_DIR=str(tmp_path / "data"), **env)
    return subprocess.run(
        [sys.executable, "-c", "import fleet.settings as s; print(s.TRUSTED_PROXIES)"],
        cwd=ROOT, env=clean, capture_output=True, text=True, timeout=60,
    )  # fmt: skip


def test_trusted_proxies_default_to_this_machine_behind_the_proxy_only(tmp_path: Path) -> None:
    assert _trusted_proxies(tmp_path).stdout.strip() == "[]"
    behind = _trusted_proxies(tmp_path, BEHIND_TLS_PROXY="1")
    assert behind.stdout.strip() == "['127.0.0.1', '::1']"
    own = _trusted_proxies(tmp_path, BEHIND_TLS_PROXY="1", TRUSTED_PROXIES="10.0.0.0/8, ::1")
    assert own.stdout.strip() == "['10.0.0.0/8', '::1']"


def test_a_trusted_proxy_that_is_not_an_address_stops_the_start(tmp_path: Path) -> None:
    result = _trusted_proxies(tmp_path, TRUSTED_PROXIES="proxy.example")
    assert result.returncode != 0
    assert "TRUSTED_PROXIES: 'proxy.example' is not an IP address or network" in result.stderr
