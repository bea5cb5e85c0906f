"""Requests that name something no database can hold are answered before they reach one."""

from __future__ import annotations

from collections.abc import Callable

from django.http import Http404, HttpRequest, HttpResponse


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
