"""Keep boat API responses small: the link is 3G or satellite and billed by the byte."""

from __future__ import annotations

from collections.abc import Callable

from django.http import HttpRequest, HttpResponse

BOAT_PREFIXES = ("/api/v1/boat/", "/spab/")
# Browser-only headers: a boat has no DOM to protect, and each costs bytes on every poll.
_DROP = (
    "X-Frame-Options",
    "Referrer-Policy",
    "Cross-Origin-Opener-Policy",
    "X-Content-Type-Options",
    "Vary",
    "Allow",
    "Strict-Transport-Security",
)


class BoatApiSlimMiddleware:
    """Outermost middleware: strips browser security headers from boat API responses."""

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponse]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponse:
        response = self.get_response(request)
        if request.path_info.startswith(BOAT_PREFIXES):
            for header in _DROP:
                # A 405 without Allow breaks RFC 9110 §15.5.6: the client needs to know.
                if header == "Allow" and response.status_code == 405:
                    continue
                if header in response.headers:
                    del response.headers[header]
        return response
