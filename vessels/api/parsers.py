"""The API's JSON parser (DEFAULT_PARSER_CLASSES). Its own module: DRF imports it while
``rest_framework.views`` is still loading, so it must not import views itself."""

from __future__ import annotations

from typing import Any

from rest_framework import exceptions, parsers


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
