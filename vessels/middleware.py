"""Boat API requests: small responses (the link is 3G or satellite and billed by the byte),
and none of the browser's middleware work (sessions, logins, messages) on the way."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from django.contrib.auth import middleware as auth
from django.contrib.messages import middleware as messages
from django.contrib.sessions import middleware as sessions
from django.http import HttpRequest, HttpResponse

# The SBD provider's webhook is a machine's post too (signed, no session): sbd/api/webhook.py.
BOAT_PREFIXES = ("/api/v1/boat/", "/spab/", "/api/v1/sbd/")
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
            self.trim(response)
        return response

    @staticmethod
    def trim(response: HttpResponse) -> None:
        for header in _DROP:
            # A 405 without Allow breaks RFC 9110 §15.5.6: the client needs to know.
            if header == "Allow" and response.status_code == 405:
                continue
            if header in response.headers:
                del response.headers[header]
        # CommonMiddleware adds "Content-Length: 0"; a 204 must not carry one (RFC 9110 §8.6).
        if response.status_code == 204 and "Content-Length" in response.headers:
            del response.headers["Content-Length"]


class BoatPathsPassBy:
    """A browser middleware that boat API requests pass by untouched.

    A boat authenticates with its key alone (vessels.auth) and its answers are JSON: it has no
    session, logged-in user or flash messages, and the boat views and their error views
    (fleet.error_views) read none. Setting them up cost a twentieth of the everyday request
    (the single-fix post, profiled; benchmark `python -m bench.server --single-only`).
    Django's checks still find each class, as subclasses of its own.
    """

    get_response: Callable[[HttpRequest], Any]

    def __call__(self, request: HttpRequest) -> Any:
        if request.path_info.startswith(BOAT_PREFIXES):
            return self.get_response(request)
        return super().__call__(request)  # type: ignore[misc]


class SessionMiddleware(BoatPathsPassBy, sessions.SessionMiddleware):
    pass


class AuthenticationMiddleware(BoatPathsPassBy, auth.AuthenticationMiddleware):
    pass


class MessageMiddleware(BoatPathsPassBy, messages.MessageMiddleware):
    pass
