"""Failed admin logins are limited per user name and client address (issue 8 #15).

After LOGIN_FAILURE_LIMIT wrong passwords for one user name from one address, that pair is
refused, without checking the password, until LOGIN_LOCKOUT_S seconds after its first
failure; a successful login clears the count. Counts live in the default cache
(settings.CACHES: share it between gunicorn workers). Another address, or another user name,
is not affected, so an attacker cannot lock an operator out from everywhere.
"""

from __future__ import annotations

import hashlib
import math
import time
from typing import Any

from django.conf import settings
from django.contrib.admin.forms import AdminAuthenticationForm
from django.core.cache import cache
from django.core.exceptions import ValidationError

from operators.clients import client_address


def _key(username: str, address: str) -> str:
    # Hashed: user names may hold characters a cache key may not; casefolded so that
    # "Alice" and "alice" share one count.
    digest = hashlib.sha256(f"{username.casefold()}\0{address}".encode()).hexdigest()
    return f"login-failures:{digest}"


def login_blocked(*, username: str, address: str) -> bool:
    count, until = cache.get(_key(username, address), (0, 0.0))
    return count >= settings.LOGIN_FAILURE_LIMIT and until > time.time()


def login_failed(*, username: str, address: str) -> None:
    """Count a failure; the count lasts LOGIN_LOCKOUT_S from the first one.

    The deadline is stored with the count and every write sets the remaining time: the file
    and database caches' incr() re-sets a key with the cache's default 300 s timeout.
    """
    key, now = _key(username, address), time.time()
    count, until = cache.get(key, (0, now + settings.LOGIN_LOCKOUT_S))
    if until <= now:
        count, until = 0, now + settings.LOGIN_LOCKOUT_S
    cache.set(key, (count + 1, until), timeout=max(1, until - now))


def login_succeeded(*, username: str, address: str) -> None:
    cache.delete(_key(username, address))


class AdminLoginForm(AdminAuthenticationForm):
    """The admin's login form, refusing a user name and address after too many failures."""

    error_messages = {
        **AdminAuthenticationForm.error_messages,
        "throttled": (
            "Too many failed logins for this user name from your address. "
            "Try again within %(minutes)d minutes."
        ),
    }

    def clean(self) -> dict[str, Any]:
        username = self.cleaned_data.get("username") or ""
        address = client_address(self.request) if self.request else ""
        if login_blocked(username=username, address=address):
            raise ValidationError(
                self.error_messages["throttled"],
                code="throttled",
                params={"minutes": math.ceil(settings.LOGIN_LOCKOUT_S / 60)},
            )
        try:
            cleaned = super().clean()
        except ValidationError as exc:
            if exc.code == "invalid_login":
                login_failed(username=username, address=address)
            raise
        login_succeeded(username=username, address=address)
        return cleaned
