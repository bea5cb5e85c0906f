"""The API's JSON parser (DEFAULT_PARSER_CLASSES). Its own module: DRF imports it while
``rest_framework.views`` is still loading, so it must not import views itself."""

from __future__ import annotations

from typing import Any

from django.conf import settings
from django.core.exceptions import RequestDataTooBig
from rest_framework import exceptions, parsers


def refuse_oversized(parser_context: Any) -> None:
    """A declared body over DATA_UPLOAD_MAX_MEMORY_SIZE is refused before it is read (a 413).

    Django checks the limit only when a body is read through ``request.body``, which some DRF
    versions bypass by reading the raw stream; this keeps the limit whatever DRF does.
    """
    request = (parser_context or {}).get("request")
    limit = settings.DATA_UPLOAD_MAX_MEMORY_SIZE
    if request is None or limit is None:
        return
    try:
        declared = int(request.META.get("CONTENT_LENGTH") or 0)
    except ValueError:
        return
    if declared > limit:
        raise RequestDataTooBig("Request body exceeded settings.DATA_UPLOAD_MAX_MEMORY_SIZE.")


class JSONParser(parsers.JSONParser):
    """DRF's JSON parser, with a deeply nested body a 400 like any other malformed JSON.

    Python's json raises RecursionError (not a ValueError) past ~1,000 levels, which DRF
    lets through as a 500; a few hundred kB of brackets is enough.
    """

    def parse(self, stream: Any, media_type: str | None = None, parser_context: Any = None) -> Any:
        refuse_oversized(parser_context)
        try:
            return super().parse(stream, media_type, parser_context)
        except RecursionError:
            raise exceptions.ParseError("JSON parse error - nested too deeply") from None
