"""Failed admin logins are limited per user name and address (operators/login.py)."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
import time_machine
from django.contrib.auth.models import User
from django.test import Client

LOGIN = "/admin/login/"
ATTACKER = "203.0.113.66"
OFFICE = "198.51.100.10"


def login(username: str, password: str, address: str = ATTACKER, **extra: Any) -> Any:
    return Client().post(
        LOGIN, {"username": username, "password": password, "next": "/admin/"},
        REMOTE_ADDR=address, **extra,
    )  # fmt: skip


def logged_in(response: Any) -> bool:
    return response.status_code == 302 and response["Location"] == "/admin/"


def refused_for_failures(response: Any) -> bool:
    return response.status_code == 200 and "Too many failed logins" in response.content.decode()


@pytest.fixture
def alice(operator_user: User) -> User:
    return operator_user  # password "pw-alice"


@pytest.fixture
def five_failures(alice: User, settings: Any) -> None:
    assert settings.LOGIN_FAILURE_LIMIT == 5
    for _ in range(5):
        response = login("alice", "guess")
        assert response.status_code == 200 and not refused_for_failures(response)


def test_the_right_password_is_refused_after_too_many_failures(five_failures: None) -> None:
    response = login("alice", "pw-alice")
    assert refused_for_failures(response)
    assert "_auth_user_id" not in response.client.session


def test_other_addresses_and_user_names_are_not_affected(
    five_failures: None, readonly_user: User
) -> None:
    assert logged_in(login("alice", "pw-alice", OFFICE))
    assert logged_in(login("bob", "pw-bob", ATTACKER))


def test_case_variants_of_a_user_name_share_the_count(five_failures: None) -> None:
    assert refused_for_failures(login("Alice", "guess"))


def test_the_lockout_ends(five_failures: None, settings: Any) -> None:
    later = dt.datetime.now(dt.UTC) + dt.timedelta(seconds=settings.LOGIN_LOCKOUT_S + 1)
    with time_machine.travel(later, tick=False):
        assert logged_in(login("alice", "pw-alice"))


def test_a_successful_login_clears_the_count(alice: User) -> None:
    for _ in range(4):
        login("alice", "guess")
    assert logged_in(login("alice", "pw-alice"))
    for _ in range(4):
        login("alice", "guess")
    assert logged_in(login("alice", "pw-alice"))


@pytest.fixture
def behind_proxy(settings: Any) -> None:
    """BEHIND_TLS_PROXY=1 with its default TRUSTED_PROXIES: the proxy on this machine."""
    settings.SECURE_PROXY_SSL_HEADER = ("HTTP_X_FORWARDED_PROTO", "https")
    settings.TRUSTED_PROXIES = ["127.0.0.1", "::1"]


def test_behind_the_proxy_the_address_it_appended_counts(alice: User, behind_proxy: None) -> None:
    for n in range(5):  # a forged first entry changes nothing
        login("alice", "guess", "127.0.0.1", HTTP_X_FORWARDED_FOR=f"10.0.0.{n}, {ATTACKER}")
    assert refused_for_failures(
        login("alice", "pw-alice", "127.0.0.1", HTTP_X_FORWARDED_FOR=f"9.9.9.9, {ATTACKER}")
    )
    assert logged_in(login("alice", "pw-alice", "127.0.0.1", HTTP_X_FORWARDED_FOR=OFFICE))


def test_a_forwarded_header_from_anyone_but_the_proxy_is_ignored(
    alice: User, behind_proxy: None
) -> None:
    """Straight to gunicorn, past the proxy: a new X-Forwarded-For per attempt would give
    each guess an address of its own and no lockout ever."""
    for n in range(5):
        login("alice", "guess", ATTACKER, HTTP_X_FORWARDED_FOR=f"10.0.0.{n}")
    assert refused_for_failures(login("alice", "pw-alice", ATTACKER, HTTP_X_FORWARDED_FOR=OFFICE))
    # The office, through the proxy, is another address and still gets in.
    assert logged_in(login("alice", "pw-alice", "127.0.0.1", HTTP_X_FORWARDED_FOR=OFFICE))


def test_without_trusted_proxies_the_header_counts_for_nothing(alice: User, settings: Any) -> None:
    settings.TRUSTED_PROXIES = []
    for n in range(5):
        login("alice", "guess", "127.0.0.1", HTTP_X_FORWARDED_FOR=f"10.0.0.{n}")
    assert refused_for_failures(login("alice", "pw-alice", "127.0.0.1"))


@pytest.fixture
def file_cache(settings: Any, tmp_path: Any) -> None:
    """The cache the README recommends under several gunicorn workers."""
    settings.CACHES = {
        "default": {
            "BACKEND": "django.core.cache.backends.filebased.FileBasedCache",
            "LOCATION": str(tmp_path / "cache"),
        }
    }


def test_with_the_file_cache_the_lockout_lasts_its_full_time(
    file_cache: None, alice: User, settings: Any
) -> None:
    start = dt.datetime.now(dt.UTC)
    with time_machine.travel(start, tick=False) as clock:
        for _ in range(5):
            login("alice", "guess")
        # Past the cache's default 300 s timeout (which its incr() would have re-set) ...
        clock.move_to(start + dt.timedelta(seconds=301))
        assert refused_for_failures(login("alice", "pw-alice"))
        # ... and free once LOGIN_LOCKOUT_S after the first failure has passed.
        clock.move_to(start + dt.timedelta(seconds=settings.LOGIN_LOCKOUT_S + 1))
        assert logged_in(login("alice", "pw-alice"))
