"""JSON for telemetry bodies, where one odd number must cost only its own fix (docs/api.md),
and the compact fixes of links that pay by the byte (edge_client/contract/compact.py).

Standard JSON has no NaN or Infinity, and Python refuses integers past 4,300 digits: DRF's
strict parser turned either into a 400 for the whole batch. Here they parse as non-finite
floats, which fix validation rejects like any other bad value, by index.
"""

from __future__ import annotations

import codecs
import json
from typing import Any

from django.conf import settings
from rest_framework.exceptions import ParseError
from rest_framework.parsers import BaseParser

from edge_client.contract import compact
from vessels.api.parsers import JSONParser, refuse_oversized

# Past ~309 digits an integer is beyond a float's range anyway: no coordinate, no reading.
MAX_INT_DIGITS = 400


def _integer(text: str) -> int | float:
    return int(text) if len(text) <= MAX_INT_DIGITS else float(text)


def loads(text: str) -> Any:
    """A telemetry body's JSON: NaN, Infinity and -Infinity as the floats of those names,
    an integer past MAX_INT_DIGITS as a float (ValueError or RecursionError for bad JSON)."""
    return json.loads(text, parse_constant=float, parse_int=_integer)


class TelemetryJSONParser(JSONParser):
    def parse(self, stream: Any, media_type: str | None = None, parser_context: Any = None) -> Any:
        refuse_oversized(parser_context)
        encoding = (parser_context or {}).get("encoding", settings.DEFAULT_CHARSET)
        try:
            return loads(codecs.getreader(encoding)(stream).read())
        except RecursionError:
            raise ParseError("JSON parse error - nested too deeply") from None
        except ValueError as exc:  # includes UnicodeDecodeError
            raise ParseError(f"JSON parse error - {exc}") from None


class LegacyTelemetryJSONParser(TelemetryJSONParser):
    """The original SPAB CGI read the body as JSON whatever the Content-Type said (or if there was
    none): old clients send none, text/plain or a form type, and must not lose telemetry."""

    media_type = "*/*"


class CompactFixesParser(BaseParser):
    """``application/vnd.shoreside.fixes``: a compact payload, decoded with the posting
    vessel's channel table into ``{"fixes": [...]}`` as JSON would have carried them (so the
    same ingest checks each fix). A payload that is not one is a 400 saying why."""

    media_type = compact.CONTENT_TYPE

    def parse(self, stream: Any, media_type: str | None = None, parser_context: Any = None) -> Any:
        refuse_oversized(parser_context)
        context = parser_context or {}
        vessel = context["view"].vessel(context["request"])  # parsed after authentication
        payload = stream.read() if stream else b""
        try:
            return {"fixes": compact.decode(payload, vessel.channel_table())}
        except compact.CompactError as exc:
            raise ParseError(f"compact fixes: {exc}") from None
