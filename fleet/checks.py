"""System checks refusing unsafe production settings. IDs are stable: document, never renumber."""

from __future__ import annotations

import sqlite3
import stat
from pathlib import Path
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


# Group and others: any of read, write, enter.
_NOT_OWNER = 0o077


def private_data_paths() -> list[Path]:
    """What only the service's user may touch: the data folder, the SQLite database (with its
    -wal and -shm, which carry the same rows) and the generated secret key, where they exist."""
    paths = [Path(settings.DATA_DIR), Path(settings.DATA_DIR) / "secret_key"]
    for db in settings.DATABASES.values():
        name = str(db.get("NAME") or "")
        if db["ENGINE"] == "django.db.backends.sqlite3" and not name.startswith((":", "file:")):
            paths += [Path(name), Path(f"{name}-wal"), Path(f"{name}-shm")]
    return [path for path in paths if path.exists()]


def loose_permissions(paths: list[Path]) -> list[tuple[Path, int]]:
    """(path, mode) for each of ``paths`` that its group or others may read, write or enter."""
    modes = [(path, stat.S_IMODE(path.stat().st_mode)) for path in paths]
    return [(path, mode) for path, mode in modes if mode & _NOT_OWNER]


@register(Tags.security)
def check_data_permissions(app_configs: Any = None, **kwargs: Any) -> list[Warning]:
    """The data folder was created 0700 and its files 0600, but an older or copied folder
    keeps whatever mode it had: vessel key hashes, operators' password hashes and the
    secret key that signs their sessions would be readable by every user of the machine."""
    return [
        Warning(
            f"{path} is open to other users (mode {mode:04o}).",
            hint=f"chmod {700 if path.is_dir() else 600} {path}",
            id="fleet.W003",
        )
        for path, mode in loose_permissions(private_data_paths())
    ]
