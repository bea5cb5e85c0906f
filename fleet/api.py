"""One error shape for the whole API: {"error": <code>, "detail": <message or field errors>}."""

from __future__ import annotations

from typing import Any

from django.core.exceptions import ValidationError as DjangoValidationError
from django.http import Http404
from rest_framework import exceptions, parsers, status
from rest_framework.response import Response
from rest_framework.views import exception_handler as drf_exception_handler


class JSONParser(parsers.JSONParser):
    """DRF's JSON parser, with a deeply nested body a 400 like any other malformed JSON.

    Python's json raises RecursionError (not a ValueError) past ~1,000 levels, which DRF
    lets through as a 500; a few hundred kB of brackets is enough.
    """

    def parse(self, stream: Any, media_type: str | None = None, parser_context: Any = None) -> Any:
        try:
            return super().parse(stream, media_type, parser_context)
        except RecursionError:
            raise exceptions.ParseError("JSON parse error - nested too deeply") from None


class Conflict(exceptions.APIException):
    status_code = status.HTTP_409_CONFLICT
    default_code = "conflict"
    default_detail = "The request conflicts with the current state."


def exception_handler(exc: Exception, context: dict[str, Any]) -> Response | None:
    if isinstance(exc, DjangoValidationError):
        detail = exc.message_dict if hasattr(exc, "error_dict") else exc.messages
        exc = exceptions.ValidationError(detail)
    if isinstance(exc, Http404):
        exc = exceptions.NotFound()
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
    return response
