"""Operator reads of telemetry: a vessel's fixes for a time range, as JSON pages or CSV."""

from __future__ import annotations

import csv
import datetime as dt
from collections.abc import Iterator
from typing import Any

from django.http import StreamingHttpResponse
from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import OpenApiParameter, OpenApiResponse, extend_schema
from rest_framework import serializers
from rest_framework.exceptions import ValidationError
from rest_framework.generics import ListAPIView
from rest_framework.pagination import CursorPagination
from rest_framework.request import Request

from telemetry.models import Fix
from telemetry.parsing import parse_time
from telemetry.selectors import fixes_in_range
from vessels.permissions import CanViewVessels, ModelPermissions
from vessels.selectors import vessel_by_slug

CSV_COLUMNS = ["recorded_at", "lat", "lon", "heading_deg", "speed_mps", "battery_v", "readings"]


class FixSerializer(serializers.ModelSerializer):
    time = serializers.DateTimeField(source="recorded_at")

    class Meta:
        model = Fix
        fields = [
            "time",
            "received_at",
            "lat",
            "lon",
            "heading_deg",
            "speed_mps",
            "battery_v",
            "readings",
        ]


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


class _Echo:
    def write(self, value: str) -> str:
        return value


# A spreadsheet runs a cell starting with these as a formula (OWASP "CSV injection"); the
# readings cell is text whose names come from the boat.
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _no_formula(text: str) -> str:
    return "'" + text if text.startswith(_FORMULA_START) else text


def _csv_rows(fixes: Any) -> Iterator[str]:
    writer = csv.writer(_Echo())
    yield writer.writerow(CSV_COLUMNS)
    for fix in fixes.iterator(chunk_size=2000):
        yield writer.writerow(
            [
                fix.recorded_at.isoformat(),
                fix.lat,
                fix.lon,
                fix.heading_deg,
                fix.speed_mps,
                fix.battery_v,
                _no_formula(";".join(f"{k}={v}" for k, v in sorted(fix.readings.items()))),
            ]
        )


@extend_schema(
    parameters=[
        OpenApiParameter("from", str, description="ISO 8601 or Unix seconds (inclusive)"),
        OpenApiParameter("to", str, description="ISO 8601 or Unix seconds (exclusive)"),
        OpenApiParameter("format", str, enum=["json", "csv"]),
    ],
    responses={
        (200, "application/json"): FixSerializer(many=True),
        (200, "text/csv"): OpenApiResponse(
            OpenApiTypes.STR, description=f"`?format=csv`: columns {', '.join(CSV_COLUMNS)}"
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
            fixes = self.get_queryset().order_by("recorded_at")
            response = StreamingHttpResponse(_csv_rows(fixes), content_type="text/csv")
            slug = self.kwargs["slug"]
            response["Content-Disposition"] = f'attachment; filename="{slug}-fixes.csv"'
            return response
        return super().list(request, *args, **kwargs)
