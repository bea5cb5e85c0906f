"""The transport interface: ``post_json(path, body, headers)``, ``post_bytes(path, data,
content_type, headers)`` and ``get(path, etag)``.

A transport returns a :class:`Response` for 2xx and 304 answers and raises
:class:`TransportError` for everything else. ``permanent=True`` means "sending the same request
again will not help" (a 4xx such as 400, 401, 404, 409); ``permanent=False`` covers timeouts,
dropped connections, 5xx and 429 (the link or server may recover). Callers look at ``status`` to
tell a bad item (drop it) from a bad key (keep everything, report).
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeVar

from edge_client.contract.backoff import doubled

log = logging.getLogger(__name__)

T = TypeVar("T")

# HTTP statuses that a retry can fix even though they are 4xx (RFC 9110 §15.5.9, RFC 6585 §4).
TEMPORARY_4XX = frozenset({408, 425, 429})


class TransportError(Exception):
    """A request did not get a usable answer."""

    def __init__(
        self, message: str, *, permanent: bool = False, status: int | None = None, body: Any = None
    ) -> None:
        super().__init__(message)
        self.permanent = permanent
        self.status = status
        self.body = body


@dataclass(frozen=True)
class Response:
    status: int
    headers: dict[str, str] = field(default_factory=dict)  # names in lower case
    body: bytes = b""

    @property
    def etag(self) -> str | None:
        return self.headers.get("etag")

    def json(self) -> Any:
        """The body as JSON; a body that is not JSON is the server's fault, not ours."""
        try:
            return json.loads(self.body.decode("utf-8"))
        except (UnicodeDecodeError, ValueError) as exc:
            raise TransportError(f"server answered {self.status} with a non-JSON body") from exc


class Transport(Protocol):
    def post_json(
        self, path: str, body: Any, headers: dict[str, str] | None = None
    ) -> Response: ...

    def post_bytes(
        self, path: str, data: bytes, content_type: str, headers: dict[str, str] | None = None
    ) -> Response: ...

    def get(self, path: str, etag: str | None = None) -> Response: ...

    def close(self) -> None: ...


def error_for_status(status: int, body: bytes) -> TransportError:
    """Turn a non-success answer into a TransportError, keeping the server's error body."""
    try:
        parsed = json.loads(body.decode("utf-8")) if body else None
    except (UnicodeDecodeError, ValueError):
        parsed = None
    detail = ""
    if isinstance(parsed, dict):
        detail = f": {parsed.get('error', '')} {parsed.get('detail', '')}".rstrip()
    permanent = 400 <= status < 500 and status not in TEMPORARY_4XX
    return TransportError(f"HTTP {status}{detail}", permanent=permanent, status=status, body=parsed)


def with_retries(
    attempt: Callable[[], T],
    *,
    retries: int,
    backoff_s: float,
    sleep: Callable[[float], None] = time.sleep,
) -> T:
    """Call ``attempt`` up to ``retries + 1`` times, doubling the pause after each temporary error.

    Permanent errors go straight to the caller. The bound is small on purpose: the outbox keeps
    everything, so giving up early just means "try again next period".
    """
    delay = backoff_s
    for n in range(retries + 1):
        try:
            return attempt()
        except TransportError as exc:
            if exc.permanent or n == retries:
                raise
            log.info("transport: %s; retrying in %.1f s", exc, delay)
            sleep(delay)
            delay = doubled(delay)
    raise AssertionError("unreachable")  # pragma: no cover
