"""Operator reads of telemetry: a vessel's fixes for a time range, as JSON pages or CSV."""

from __future__ import annotations

import datetime as dt
from typing import Any

from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import OpenApiParameter, OpenApiResponse, extend_schema
from rest_framework import serializers
from rest_framework.exceptions import ValidationError
from rest_framework.generics import ListAPIView
from rest_framework.pagination import CursorPagination
from rest_framework.request import Request

from edge_client.contract import fix as fix_shape
from telemetry.api import export
from telemetry.models import Fix
from telemetry.parsing import parse_time
from telemetry.selectors import fixes_in_range
from vessels.permissions import CanViewVessels, ModelPermissions
from vessels.selectors import vessel_by_slug


class FixSerializer(serializers.ModelSerializer):
    time = serializers.DateTimeField(source="recorded_at")

    class Meta:
        model = Fix
        # The fix as the boat posted it (edge_client.contract.fix), received_at after its time.
        fields = [fix_shape.FIELDS[0], "received_at", *fix_shape.FIELDS[1:]]


class FixCursor(CursorPagination):
    # Cursor paging stays cheap deep into millions of rows: no OFFSET, no COUNT.
    ordering = "recorded_at"
    page_size = 500
    page_size_query_param = "page_size"
    max_page_size = 5000


def time_param(request: Request, name: str) -> dt.datetime | None:
    raw = request.query_params.get(name)
    if not raw:
        return None
    value: Any = raw
    try:
        value = float(raw)
    except ValueError:
        pass
    try:
        return parse_time(value, now=dt.datetime.now(dt.UTC), max_future_s=10 * 365 * 86400)
    except ValueError as exc:
        raise ValidationError({name: [f"{raw!r} {exc}"]}) from None


@extend_schema(
    parameters=[
        OpenApiParameter("from", str, description="ISO 8601 or Unix seconds (inclusive)"),
        OpenApiParameter("to", str, description="ISO 8601 or Unix seconds (exclusive)"),
        OpenApiParameter("format", str, enum=["json", "csv"]),
    ],
    responses={
        (200, "application/json"): FixSerializer(many=True),
        (200, "text/csv"): OpenApiResponse(
            OpenApiTypes.STR,
            description=f"`?format=csv`: the export's CSV, columns {export.CSV_HEADER.strip()}",
        ),
    },
    tags=["operator"],
)
class VesselFixesView(ListAPIView):
    """A vessel's fixes in a time range: cursor-paginated JSON, or `?format=csv`."""

    serializer_class = FixSerializer
    pagination_class = FixCursor
    queryset = Fix.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions, CanViewVessels]

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        return fixes_in_range(
            vessel=vessel_by_slug(self.kwargs["slug"]),
            start=time_param(self.request, "from"),
            end=time_param(self.request, "to"),
        )

    def list(self, request: Request, *args: Any, **kwargs: Any) -> Any:
        if request.query_params.get("format") == "csv":
            # The export's writer: the same file as /track/export/?format=csv for a range.
            slug = self.kwargs["slug"]
            start, end = time_param(request, "from"), time_param(request, "to")
            chunks = export.csv_chunks(vessel_by_slug(slug).pk, start, end)
            return export.streamed(chunks, fmt="csv", filename=f"{slug}-fixes.csv")
        return super().list(request, *args, **kwargs)
