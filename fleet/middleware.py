"""Requests that name something no database can hold are answered before they reach one, and
a view whose database went away is a 503, not a 500."""

from __future__ import annotations

import logging
from collections.abc import Callable

from django.http import Http404, HttpRequest, HttpResponse

from fleet import error_views
from vessels.database import database_unavailable

logger = logging.getLogger(__name__)


class RejectNulMiddleware:
    """A NUL in the path or the query string is a 404.

    PostgreSQL cannot hold NUL in text, so a slug or an admin filter value carrying one
    (`/api/v1/vessels/%00/`, `?status__exact=%00`) failed in the database as a 500. Nothing
    stored can match such a value: "not found" is the true answer, for every view at once.
    """

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponse]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponse:
        if "\x00" in request.path_info or "%00" in request.META.get("QUERY_STRING", ""):
            raise Http404("NUL in the request")
        return self.get_response(request)


class DatabaseUnavailableMiddleware:
    """A view that loses its database (a restart, a failover) answers 503 with Retry-After.

    The API's views get this from its exception handler (fleet.api); this covers the rest:
    the admin and the map pages (an HTML page) and anything that escaped a DRF view (JSON
    under /api/, a telemAck under /spab/). Nothing was committed: a reload works.
    """

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponse]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponse:
        return self.get_response(request)

    def process_exception(self, request: HttpRequest, exception: Exception) -> HttpResponse | None:
        if not database_unavailable(exception):
            return None
        logger.warning("database unavailable, answered 503 to %s: %s", request.path, exception)
        return error_views.database_unavailable(request)
