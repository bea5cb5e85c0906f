"""Failed admin logins are limited per user name and client address (issue 8 #15), and every
login, failed login and logout is in the audit log.

After LOGIN_FAILURE_LIMIT wrong passwords for one user name from one address, that pair is
refused, without checking the password, until LOGIN_LOCKOUT_S seconds after its first
failure; a successful login clears the count. Counts live in the default cache
(settings.CACHES: share it between gunicorn workers). Another address, or another user name,
is not affected, so an attacker cannot lock an operator out from everywhere.

The audit entries come from Django's own auth signals (user_logged_in, user_login_failed,
user_logged_out), connected in OperatorsConfig.ready(): no service of ours logs anyone in, and
django.contrib.auth raises them for every way in (the admin's form, a test's force_login, any
later login view), so no login path can forget them. They live here, beside the failure
limit, because this app owns the operators' credentials. A refusal by the limit (no password
checked, so no signal) is logged as ``login.throttled`` by the form.
"""

from __future__ import annotations

import hashlib
import math
import time
from typing import Any

from django.conf import settings
from django.contrib.admin.forms import AdminAuthenticationForm
from django.contrib.auth.base_user import AbstractBaseUser
from django.core.cache import cache
from django.core.exceptions import ValidationError
from django.http import HttpRequest

from audit.services import audit_record
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
            _audit_login("login.throttled", username, self.request)
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


# -- the audit log's receivers for django.contrib.auth's signals (see the module docstring) --


def _audit_login(action: str, username: str, request: HttpRequest | None) -> None:
    # The address from the signal's own request (authenticate() may be called outside the
    # middleware's origin); the way in from the origin (audit.context), when there is one.
    audit_record(
        action=action,
        actor=username,
        subject_type="operator",
        subject=username,
        ip=client_address(request) if request is not None else None,
    )


def audit_logged_in(sender: Any, request: HttpRequest, user: AbstractBaseUser, **kw: Any) -> None:
    _audit_login("login.succeeded", user.get_username(), request)


def audit_login_failed(
    sender: Any, credentials: dict[str, Any], request: HttpRequest | None = None, **kw: Any
) -> None:
    # credentials has the password masked by Django; only the name tried is kept.
    _audit_login("login.failed", str(credentials.get("username", "")), request)


def audit_logged_out(
    sender: Any, request: HttpRequest, user: AbstractBaseUser | None, **kw: Any
) -> None:
    if user is not None:  # logging out without being logged in is nobody's action
        _audit_login("login.logged_out", user.get_username(), request)
