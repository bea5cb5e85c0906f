"""The audit origin of a web request (audit.context): who is logged in, through the admin or
the API, from which address."""

from __future__ import annotations

from collections.abc import Callable

from django.http import HttpRequest, HttpResponse

from audit.context import Origin, audit_origin
from audit.models import ActorKind
from operators.clients import client_address


def request_origin(request: HttpRequest) -> Origin:
    """Read when the first entry is written, not before: by then the view's authentication
    (a session, a token) has set ``request.user``, and the URL has been resolved."""
    match = request.resolver_match
    if match is not None and "admin" in match.namespaces:
        via = "admin"
    elif request.path_info.startswith("/api/"):
        via = "api"
    else:
        via = "web"
    actor, kind = "", ActorKind.OPERATOR
    user = getattr(request, "user", None)
    if user is not None and user.is_authenticated:
        if hasattr(user, "get_username"):
            actor = user.get_username()
        elif hasattr(user, "vessel"):  # vessels.auth.BoatPrincipal: a boat's own request
            actor, kind = user.vessel.slug, ActorKind.VESSEL
    return Origin(actor=actor, actor_kind=kind, via=via, ip=client_address(request))


class AuditOriginMiddleware:
    """Sets the lazy origin for the request (after AuthenticationMiddleware): nothing is read
    unless an audit entry is written, so the boat's fix posts and polls pay nothing else."""

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponse]) -> None:
        self.get_response = get_response

    def __call__(self, request: HttpRequest) -> HttpResponse:
        with audit_origin(lambda: request_origin(request)):
            return self.get_response(request)
