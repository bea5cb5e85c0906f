"""The boat API's HTTP traffic, counted per vessel without a write per request.

The single-fix post is the hot path (``python -m bench.server --single-only``), so a request
only adds to a per-process tally (:class:`Tally`, under a lock); the tally is written with one
upsert per (vessel, day) at most every LINK_FLUSH_S seconds, after a response, and at process
exit. A worker killed hard (SIGKILL, OOM) loses at most that many seconds of HTTP counts.

Bytes are those the application sees: the request line, headers and body as received, the
status line, headers and body as answered; what a proxy or gunicorn adds (``Date``,
``Server``, chunking, TLS) is not counted.
"""

from __future__ import annotations

import atexit
import datetime as dt
import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from django.conf import settings
from django.db import DatabaseError, transaction
from django.http import HttpRequest, HttpResponseBase
from django.utils import timezone

from links.models import Transport
from links.sql import link_day_add
from vessels.middleware import BOAT_PREFIXES, BoatApiSlimMiddleware
from vessels.models import Vessel

logger = logging.getLogger(__name__)
# What a view that ingested fixes leaves on the HttpRequest: how many it accepted.
FIXES_ATTR = "link_fixes_in"
# messages_in, bytes_in, bytes_out, fixes_in, last contact.
_EMPTY = (0, 0, 0, 0, None)


class Tally:
    """Counts per (vessel id, UTC day), added under a lock and taken whole by a flush."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.lock = threading.Lock()
        self.counts: dict[tuple[int, dt.date], list[Any]] = {}
        self.clock = clock
        self.flushed_at = clock()

    def add(
        self, vessel_id: int, at: dt.datetime, bytes_in: int, bytes_out: int, fixes: int
    ) -> None:
        key = (vessel_id, at.astimezone(dt.UTC).date())
        with self.lock:
            row = self.counts.get(key)
            if row is None:
                self.counts[key] = [1, bytes_in, bytes_out, fixes, at]
            else:
                row[0] += 1
                row[1] += bytes_in
                row[2] += bytes_out
                row[3] += fixes
                row[4] = at

    def due(self, every_s: float) -> bool:
        return bool(self.counts) and self.clock() - self.flushed_at >= every_s

    def take(self) -> dict[tuple[int, dt.date], list[Any]]:
        with self.lock:
            counts, self.counts = self.counts, {}
            self.flushed_at = self.clock()
        return counts

    def flush(self) -> int:
        """Write what was counted, one upsert per (vessel, day); rows written. Counts of a
        vessel deleted meanwhile are dropped; a database that fails loses this batch (logged),
        never the request."""
        counts = self.take()
        if not counts:
            return 0
        try:
            alive = set(
                Vessel.objects.filter(pk__in={v for v, _ in counts}).values_list("pk", flat=True)
            )
            with transaction.atomic():
                for (vessel_id, day), (n, b_in, b_out, fixes, at) in sorted(counts.items()):
                    if vessel_id in alive:
                        link_day_add(
                            vessel_id=vessel_id,
                            day=day,
                            transport=Transport.HTTP,
                            counts={"messages_in": n, "messages_out": n, "bytes_in": b_in,
                                    "bytes_out": b_out, "fixes_in": fixes},
                            contact_at=at,
                        )  # fmt: skip
        except DatabaseError:
            logger.exception("links: HTTP counts of %d vessel-days lost", len(counts))
            return 0
        return len(counts)

    def clear(self) -> None:
        self.take()


TALLY = Tally()


def _flush_at_exit() -> None:
    try:
        TALLY.flush()
    except Exception:  # the interpreter is going: the database may be too
        logger.exception("links: HTTP counts lost at exit")


atexit.register(_flush_at_exit)


def request_bytes(request: HttpRequest) -> int:
    """The request line, headers and body as received (WSGI keeps the headers in META)."""
    meta = request.META
    size = len(request.method or "") + len(meta.get("RAW_URI") or request.get_full_path()) + 12
    for key, value in meta.items():
        if key.startswith("HTTP_"):
            size += len(key) - 5 + len(value) + 4
    for key in ("CONTENT_TYPE", "CONTENT_LENGTH"):
        if meta.get(key):
            size += len(key) + len(meta[key]) + 4
    try:
        size += int(meta.get("CONTENT_LENGTH") or 0)
    except ValueError:
        pass
    return size + 2


def response_bytes(response: HttpResponseBase) -> int:
    """The status line, headers and body as answered (a streamed body is not counted)."""
    size = 15 + len(response.reason_phrase or "")
    for key, value in response.items():
        size += len(key) + len(value) + 4
    if not getattr(response, "streaming", False):
        size += len(response.content)  # type: ignore[attr-defined]
    return size + 2


class BoatApiMiddleware(BoatApiSlimMiddleware):
    """Outermost, in BoatApiSlimMiddleware's place: trims a boat API response as it does,
    then counts the request of an authenticated vessel as answered and flushes the tally
    when due. One middleware, not two: no stack frame more under the view (a deeply nested
    body is parsed near the recursion limit, tests/sms/test_boat_api.py)."""

    def __call__(self, request: HttpRequest) -> HttpResponseBase:  # type: ignore[override]
        response = self.get_response(request)
        if not request.path_info.startswith(BOAT_PREFIXES):
            return response
        self.trim(response)  # type: ignore[arg-type]
        # DRF's authentication sets the HttpRequest's user too: a BoatPrincipal. The SBD
        # webhook has none (the provider's post, counted as SBD by the sbd app).
        vessel = getattr(getattr(request, "user", None), "vessel", None)
        if vessel is None:
            return response  # not a vessel's request (refused, a stranger): not its traffic
        TALLY.add(
            vessel.pk,
            timezone.now(),
            request_bytes(request),
            response_bytes(response),
            getattr(request, FIXES_ATTR, 0),
        )
        if TALLY.due(settings.LINK_FLUSH_S):
            TALLY.flush()
        return response
