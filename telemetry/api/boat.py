"""Telemetry in from boats: v1 `POST /api/v1/boat/telemetry/` and the thesis' `data.cgi`.

The wire shapes are a contract with boats in the field (DESIGN §5), so these are explicit
APIViews that build their JSON by hand; :func:`telemetry.services.fix_ingest` does the work.
"""

from __future__ import annotations

from typing import Any

from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import extend_schema, inline_serializer
from rest_framework import serializers, status
from rest_framework.exceptions import ParseError
from rest_framework.request import Request
from rest_framework.response import Response

from telemetry.api.parsers import LegacyTelemetryJSONParser, TelemetryJSONParser
from telemetry.services import fix_ingest
from vessels.api.boat import BoatView, LegacyBoatView, telem_ack


def records_from_body(data: Any) -> list[Any]:
    """A list of fixes, or {"fixes": [...]}; anything else is a 400 naming the problem."""
    if isinstance(data, dict) and "fixes" in data:
        data = data["fixes"]
    if not isinstance(data, list):
        raise ParseError('Expected a JSON list of fixes, or an object {"fixes": [...]}.')
    return data


_IngestResult = inline_serializer(
    "IngestResult",
    {
        "accepted": serializers.IntegerField(),
        "duplicates": serializers.IntegerField(),
        "rejected": serializers.ListField(child=serializers.DictField()),
    },
)


class TelemetryView(BoatView):
    parser_classes = [TelemetryJSONParser]

    @extend_schema(request=OpenApiTypes.OBJECT, responses={200: _IngestResult}, tags=["boat"])
    def post(self, request: Request) -> Response:
        """Store a batch of fixes. Bad fixes are reported by index; the good ones are kept."""
        result = fix_ingest(vessel=self.vessel(request), records=records_from_body(request.data))
        return Response(result.as_dict())


@extend_schema(exclude=True)
class LegacyDataView(LegacyBoatView):
    """`POST /spab/data.cgi`: Listing 1 records (one object or a list) → `telemAck`."""

    parser_classes = [LegacyTelemetryJSONParser]

    def post(self, request: Request) -> Response:
        data = request.data
        records = [data] if isinstance(data, dict) else data
        if not isinstance(records, list):
            return Response(
                telem_ack(False, "expected a JSON object or a list of objects"),
                status=status.HTTP_400_BAD_REQUEST,
            )
        result = fix_ingest(vessel=self.vessel(request), records=records, legacy=True)
        message = (
            f"accepted {result.accepted}, duplicates {result.duplicates}, "
            f"rejected {len(result.rejected)}"
        )
        for rejected in result.rejected:
            fields = ", ".join(f"{k} {v}" for k, v in rejected["errors"].items())
            message += f"; record {rejected['index']}: {fields}"
        ok = not result.rejected
        return Response(
            telem_ack(ok, message),
            status=200 if ok or result.accepted or result.duplicates else 400,
        )
