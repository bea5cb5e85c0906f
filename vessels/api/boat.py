"""The base every boat endpoint stands on: key authentication, JSON only, one parser.

The v1 endpoints and the original SPAB's legacy CGI endpoints live in the app that owns their data
(telemetry, commands); what they share about *talking to a boat* lives here, beside the key
authentication.
"""

from __future__ import annotations

from typing import Any

from django.utils.dateparse import parse_datetime
from drf_spectacular.utils import inline_serializer
from rest_framework import serializers
from rest_framework.negotiation import DefaultContentNegotiation
from rest_framework.renderers import JSONRenderer
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from edge_client.contract import batch
from vessels.api.parsers import JSONParser
from vessels.auth import LegacyKeyAuthentication, VesselKeyAuthentication
from vessels.models import Vessel
from vessels.permissions import IsBoat
from vessels.text import unstorable


class JsonOnly(DefaultContentNegotiation):
    """The boat API answers JSON whatever the Accept header says (old modem clients send odd
    ones); parsing Accept on every poll cost more than the poll's own query (profiled)."""

    def select_renderer(
        self, request: Request, renderers: list[Any], format_suffix: Any = None
    ) -> tuple[Any, str]:
        return renderers[0], renderers[0].media_type


class BoatView(APIView):
    """A v1 boat endpoint: `Authorization: Api-Key <key>`, JSON in and out."""

    authentication_classes = [VesselKeyAuthentication]
    permission_classes = [IsBoat]
    parser_classes = [JSONParser]
    renderer_classes = [JSONRenderer]
    content_negotiation_class = JsonOnly

    def vessel(self, request: Request) -> Vessel:
        return request.user.vessel


class AwareDateTimeField(serializers.DateTimeField):
    """A vessel's time: ISO 8601 with a UTC offset, as telemetry takes it.

    DRF would read a naive time as the site's zone (UTC here), a guess about a vessel's
    clock that telemetry refuses to make; and Python's ISO parser stops at a NUL, so
    ``...T10:00:00Z\x00junk`` parsed as a time. Both are refused, saying why.
    """

    default_error_messages = {"naive": "needs a UTC offset, e.g. 2026-11-23T10:00:00Z"}

    def to_internal_value(self, value: Any) -> Any:
        if isinstance(value, str):
            if problem := unstorable(value):
                raise serializers.ValidationError(problem, code="invalid")
            try:
                parsed = parse_datetime(value)
            except ValueError:
                parsed = None  # out of range: DRF's own message below
            if parsed is not None and parsed.tzinfo is None:
                self.fail("naive")
        return super().to_internal_value(value)


def batch_answer_schema(
    name: str, extra: dict[str, serializers.Field] | None = None
) -> serializers.Serializer:
    """The API schema of a batch upload's answer (edge_client.contract.batch), named ``name``,
    with the ``extra`` fields an endpoint may add after the contract's."""
    counts = (serializers.IntegerField(), serializers.IntegerField())
    rejected = serializers.ListField(child=serializers.DictField())
    fields = dict(zip(batch.KEYS, (*counts, rejected), strict=True))
    return inline_serializer(name, {**fields, **(extra or {})})


def telem_ack(success: bool, message: str) -> list[dict[str, str]]:
    """The legacy answer shape (docs/api.md): `[{"type": "telemAck"}, {...}]`."""
    return [{"type": "telemAck"}, {"success": "true" if success else "false", "message": message}]


class LegacyBoatView(APIView):
    """A legacy SPAB endpoint (docs/api.md#legacy-spab-endpoints): key by header, Basic
    or `?key=`; every error answered as a `telemAck`, the only shape the old client reads."""

    authentication_classes = [LegacyKeyAuthentication]
    permission_classes = [IsBoat]

    def vessel(self, request: Request) -> Vessel:
        return request.user.vessel

    def handle_exception(self, exc: Exception) -> Response:
        # The project's exception handler has already given the error its status code and
        # {"error", "detail"} body; keep the code, re-word the body for the old client.
        response = super().handle_exception(exc)
        data = response.data
        detail = data.get("detail", data) if isinstance(data, dict) else data
        response.data = telem_ack(False, str(detail))
        return response
