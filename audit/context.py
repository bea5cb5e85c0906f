"""Who is acting, through what and from where: the origin an audit entry is written under.

A service knows *what* it did; the way in (the admin, the API, a shell) and the client's
address are known only where the call entered the site. Rather than thread ``ip=`` and
``via=`` through every service and all of its callers (the admin, the API views, the SMS path,
the management commands), each entry point states its origin once and audit_record reads it:

- a web request: ``operators.middleware.AuditOriginMiddleware`` sets a *lazy* origin (the
  logged-in user, ``admin`` or ``api`` by URL, the client's address by the TRUSTED_PROXIES
  rule of operators.clients), worked out only when an entry is written, so the requests that
  write none (the boat's fix posts and polls) pay nothing but setting a context variable;
- a management command: subclass AuditedCommand (the shell user who ran it, ``cli``);
- anything else (the alerts loop, the glider's bridge) has no origin: its entries say what
  the service was told, nothing more.

The origin only fills what the service left blank: a service that knows better (a command's
``created_by`` and ``source``, an SMS sender's number) says so, and its word wins. The client's
address is filled in for an operator only: an SMS relayed by a glider comes from the glider's
address, which is not where the phone is.

A ContextVar, not a thread-local: right under threads and asyncio alike, and reset on the way
out, so nothing leaks into the next request a worker serves.
"""

from __future__ import annotations

import functools
import getpass
from collections.abc import Callable
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

from django.core.management.base import BaseCommand

from audit.models import ActorKind


@dataclass(frozen=True)
class Origin:
    actor: str = ""
    actor_kind: str = ActorKind.OPERATOR
    via: str = ""
    ip: str | None = None


NOWHERE = Origin()
# An Origin, or a function that works one out on first use (a request's; see module doc).
_current: ContextVar[Origin | Callable[[], Origin] | None] = ContextVar(
    "audit_origin", default=None
)


class audit_origin:  # noqa: N801 (used as a function: ``with audit_origin(...):``)
    """Entries written inside the block take their blanks from ``origin``.

    A class, not @contextmanager: every request enters one, and this is the cheaper of the
    two (no generator); what remains is the ContextVar's own set and reset.
    """

    __slots__ = ("origin", "token")

    def __init__(self, origin: Origin | Callable[[], Origin]) -> None:
        self.origin = origin

    def __enter__(self) -> None:
        self.token = _current.set(self.origin)

    def __exit__(self, *exc: object) -> None:
        _current.reset(self.token)


def current_origin() -> Origin:
    """The origin in force (NOWHERE outside any), working a lazy one out once."""
    origin = _current.get()
    if origin is None:
        return NOWHERE
    if not isinstance(origin, Origin):
        origin = origin()
        _current.set(origin)  # in this context only; reset with it
    return origin


def cli_origin() -> Origin:
    """A management command's: the shell user who ran it, through ``cli``."""
    try:
        user = getpass.getuser()
    except (KeyError, OSError):  # no passwd entry and no LOGNAME (a bare container)
        user = ""
    return Origin(actor=f"{user or 'unknown'} (manage.py)", actor_kind=ActorKind.SYSTEM, via="cli")


class AuditedCommand(BaseCommand):
    """A management command whose services' audit entries name the shell user, via ``cli``.

    Subclasses write ``handle()`` as usual; it runs inside the origin (wrapped here once per
    class, so ``call_command`` and ``manage.py`` alike get it).
    """

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        handle = cls.__dict__.get("handle")
        if handle is None:
            return

        @functools.wraps(handle)
        def audited(self: BaseCommand, *args: Any, **options: Any) -> Any:
            with audit_origin(cli_origin()):
                return handle(self, *args, **options)

        cls.handle = audited
