"""One error shape for the whole API: {"error": <code>, "detail": <message or field errors>}."""

from __future__ import annotations

import logging
from typing import Any

from django.core.exceptions import RequestDataTooBig
from django.core.exceptions import ValidationError as DjangoValidationError
from django.http import Http404
from rest_framework import exceptions, status
from rest_framework.response import Response
from rest_framework.views import exception_handler as drf_exception_handler

from commands.errors import CatalogError, CommandError, CommandNotFound, TransitionError
from fleet.error_views import too_large_detail
from telemetry.errors import TelemetryError
from vessels.database import RETRY_AFTER_S, database_unavailable
from vessels.errors import VesselsError

logger = logging.getLogger(__name__)


class Conflict(exceptions.APIException):
    status_code = status.HTTP_409_CONFLICT
    default_code = "conflict"
    default_detail = "The request conflicts with the current state."


class TooLarge(exceptions.APIException):
    status_code = status.HTTP_413_REQUEST_ENTITY_TOO_LARGE
    default_code = "too_large"


class DatabaseUnavailable(exceptions.APIException):
    """The database went away mid-request (a restart, a failover): nothing was committed,
    and the same request will work in a moment. Boats retry from their outbox."""

    status_code = status.HTTP_503_SERVICE_UNAVAILABLE
    default_code = "database_unavailable"
    default_detail = "The database is unavailable for a moment; retry shortly."
    retry_after_s = RETRY_AFTER_S


def domain_to_api(exc: Exception) -> Exception:
    """The apps' own errors as DRF exceptions: the one place they become HTTP answers.

    Not found → 404, an illegal status transition → 409, any other command error → 400
    naming the field. Catalog errors name a parameter, which the API body nests in `params`;
    a vessels error (a mission check, a mission file) lists every problem under its field.
    """
    if isinstance(exc, CommandNotFound):
        return exceptions.NotFound(exc.message)
    if isinstance(exc, TransitionError):
        return Conflict(exc.message)
    if isinstance(exc, CatalogError):
        return exceptions.ValidationError(
            {"kind" if exc.field == "kind" else "params": [exc.message]}
        )
    if isinstance(exc, CommandError):
        return exceptions.ValidationError(exc.as_dict())
    if isinstance(exc, RequestDataTooBig):
        return TooLarge(too_large_detail())
    if database_unavailable(exc):
        logger.warning("database unavailable, answered 503: %s", exc)
        return DatabaseUnavailable()
    if isinstance(exc, VesselsError):
        return exceptions.ValidationError(exc.as_dict())
    if isinstance(exc, TelemetryError):
        return exceptions.ParseError(exc.message)
    if isinstance(exc, DjangoValidationError):
        detail = exc.message_dict if hasattr(exc, "error_dict") else exc.messages
        return exceptions.ValidationError(detail)
    if isinstance(exc, Http404):
        return exceptions.NotFound()
    return exc


def exception_handler(exc: Exception, context: dict[str, Any]) -> Response | None:
    exc = domain_to_api(exc)
    response = drf_exception_handler(exc, context)
    if response is None:
        return None
    if isinstance(exc, exceptions.APIException):
        code = exc.get_codes()
        if not isinstance(code, str):
            code = "invalid"
        # DRF wraps plain errors as {"detail": msg}; a ValidationError's dict is field errors,
        # where "detail" may be a field's own name (the ack's `detail`), so it stays whole.
        detail = (
            response.data.get("detail", response.data)
            if isinstance(response.data, dict) and not isinstance(exc, exceptions.ValidationError)
            else response.data
        )
        response.data = {"error": code, "detail": detail}
    if isinstance(exc, DatabaseUnavailable):
        response["Retry-After"] = str(exc.retry_after_s)
    return response
