"""Django's error pages, as JSON under /api/ and as a telemAck under /spab/ (the boats' paths).

These answer what never reached a DRF view or escaped it: an unmatched URL, a body over
DATA_UPLOAD_MAX_MEMORY_SIZE, an unhandled exception. Everywhere else, Django's own pages.
"""

from __future__ import annotations

from django.conf import settings
from django.core.exceptions import RequestDataTooBig
from django.http import HttpRequest, HttpResponse, JsonResponse
from django.views import defaults

from vessels.database import RETRY_AFTER_S

API_PREFIX = "/api/"
LEGACY_PREFIX = "/spab/"


def _json(request: HttpRequest, status: int, code: str, detail: str) -> HttpResponse | None:
    path = request.path_info
    if path.startswith(API_PREFIX):
        return JsonResponse({"error": code, "detail": detail}, status=status)
    if path.startswith(LEGACY_PREFIX):
        body = [{"type": "telemAck"}, {"success": "false", "message": detail}]
        return JsonResponse(body, status=status, safe=False)
    return None


def too_large_detail() -> str:
    return f"The body is over {settings.DATA_UPLOAD_MAX_MEMORY_SIZE} bytes; send smaller batches."


def bad_request(request: HttpRequest, exception: Exception) -> HttpResponse:
    if isinstance(exception, RequestDataTooBig):
        answer = _json(request, 413, "too_large", too_large_detail())
    else:
        answer = _json(request, 400, "bad_request", "The request could not be understood.")
    return answer or defaults.bad_request(request, exception)


def permission_denied(request: HttpRequest, exception: Exception) -> HttpResponse:
    answer = _json(request, 403, "permission_denied", "You may not do that.")
    return answer or defaults.permission_denied(request, exception)


def page_not_found(request: HttpRequest, exception: Exception) -> HttpResponse:
    answer = _json(request, 404, "not_found", "No such endpoint.")
    return answer or defaults.page_not_found(request, exception)


def server_error(request: HttpRequest) -> HttpResponse:
    answer = _json(request, 500, "server_error", "Something went wrong on the server.")
    return answer or defaults.server_error(request)


def database_unavailable(request: HttpRequest) -> HttpResponse:
    """The database went away mid-request: a 503 the same request may retry after a moment."""
    detail = "The database is unavailable for a moment; retry shortly."
    answer = _json(request, 503, "database_unavailable", detail) or HttpResponse(
        f"<h1>Service unavailable</h1><p>{detail}</p>", status=503
    )
    answer["Retry-After"] = str(RETRY_AFTER_S)
    return answer
