"""System checks refusing unsafe production settings. IDs are stable: document, never renumber."""

from __future__ import annotations

import sqlite3
from typing import Any

from django.conf import settings
from django.core.checks import Error, Tags, Warning, register

# telemetry.services.fix_ingest uses INSERT … ON CONFLICT DO NOTHING RETURNING (SQLite 3.35).
SQLITE_MIN = (3, 35)

_LOCAL_HOSTS = {"localhost", "127.0.0.1", "[::1]", "::1", ".localhost"}


@register(Tags.security, deploy=False)
def check_production_safety(app_configs: Any = None, **kwargs: Any) -> list[Error | Warning]:
    problems: list[Error | Warning] = []
    hosts = set(settings.ALLOWED_HOSTS)
    if settings.DEBUG and (hosts - _LOCAL_HOSTS):
        problems.append(
            Error(
                "DEBUG is on while ALLOWED_HOSTS names non-local hosts.",
                hint="Set DEBUG=0 on any server reachable from outside this machine.",
                id="fleet.E001",
            )
        )
    if not settings.PRODUCTION and (hosts - _LOCAL_HOSTS):
        problems.append(
            Warning(
                "Serving non-local hosts without PRODUCTION=1: cookies may travel over plain "
                "HTTP and SECRET_KEY may be a generated local one.",
                hint="Set PRODUCTION=1 and SECRET_KEY for any server reachable from outside.",
                id="fleet.W002",
            )
        )
    if settings.PRODUCTION:
        if len(settings.SECRET_KEY) < 40:
            problems.append(
                Error(
                    "PRODUCTION is on but SECRET_KEY is shorter than 40 characters.",
                    hint="Set SECRET_KEY in the environment (python -c "
                    "'import secrets; print(secrets.token_urlsafe(50))').",
                    id="fleet.E002",
                )
            )
        if settings.DEBUG:
            problems.append(
                Error("PRODUCTION and DEBUG are both on.", hint="Set DEBUG=0.", id="fleet.E003")
            )
        if not (settings.SESSION_COOKIE_SECURE and settings.CSRF_COOKIE_SECURE):
            problems.append(
                Error(
                    "PRODUCTION is on but session/CSRF cookies may travel over plain HTTP.",
                    hint="Leave SESSION_COOKIE_SECURE and CSRF_COOKIE_SECURE on in production.",
                    id="fleet.E004",
                )
            )
        if not settings.ALLOWED_HOSTS or "*" in settings.ALLOWED_HOSTS:
            problems.append(
                Error(
                    "PRODUCTION is on but ALLOWED_HOSTS is empty or '*'.",
                    hint="Set ALLOWED_HOSTS to the site's host names.",
                    id="fleet.E005",
                )
            )
        if not settings.SECURE_SSL_REDIRECT:
            problems.append(
                Warning(
                    "PRODUCTION is on without SECURE_SSL_REDIRECT.",
                    hint="Only turn it off when a TLS proxy already redirects plain HTTP.",
                    id="fleet.W001",
                )
            )
    return problems


@register(Tags.compatibility)
def check_sqlite_version(app_configs: Any = None, **kwargs: Any) -> list[Error]:
    """Django runs on SQLite 3.31, but every fix ingest would fail below 3.35."""
    uses_sqlite = any(
        db["ENGINE"] == "django.db.backends.sqlite3" for db in settings.DATABASES.values()
    )
    if not uses_sqlite or sqlite3.sqlite_version_info >= SQLITE_MIN:
        return []
    found = ".".join(str(n) for n in sqlite3.sqlite_version_info)
    return [
        Error(
            f"SQLite {found} is too old: the fix ingest needs {SQLITE_MIN[0]}.{SQLITE_MIN[1]} "
            "or newer (INSERT … RETURNING).",
            hint="Use a Python built against a newer SQLite, or set DATABASE_URL to PostgreSQL.",
            id="fleet.E006",
        )
    ]
