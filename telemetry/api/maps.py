"""The maps' reads (issue 9): a vessel's simplified track, the fix nearest a time, plot
series and full-resolution exports. Operator API, the rights of the fixes endpoint."""

from __future__ import annotations

import datetime as dt
import json
from typing import Any

from django.http import HttpResponse, StreamingHttpResponse
from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import OpenApiParameter, OpenApiResponse, extend_schema
from rest_framework.exceptions import NotFound, ValidationError
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from telemetry.api import export
from telemetry.api.schemas import SeriesSerializer, TrackSerializer
from telemetry.api.views import FixSerializer, time_param
from telemetry.models import Fix, SensorChannel
from telemetry.overview import BATTERY
from telemetry.selectors import fix_nearest
from telemetry.simplify import MIN_POINTS
from telemetry.track import Track, gap_seconds, series, track
from vessels.models import Vessel
from vessels.permissions import CanViewVessels, ModelPermissions
from vessels.selectors import vessel_by_slug

DEFAULT_RANGE = dt.timedelta(hours=24)
TRACK_DEFAULT_POINTS = 2000
TRACK_MAX_POINTS = 10000
SERIES_DEFAULT_BUCKETS = 1000
SERIES_MAX_BUCKETS = 5000
COORD_DECIMALS = 6  # ~0.1 m: finer than any GPS, and the track stays under 120 kB
RANGE_PARAMETERS = [
    OpenApiParameter(
        "from", str, description="ISO 8601 or Unix seconds (inclusive); default `to` − 24 h"
    ),
    OpenApiParameter("to", str, description="ISO 8601 or Unix seconds (exclusive); default now"),
]


def range_params(request: Request) -> tuple[dt.datetime, dt.datetime]:
    """`from`/`to` with the map's default (the last 24 h); `from` must come before `to`."""
    end = time_param(request, "to") or dt.datetime.now(dt.UTC)
    start = time_param(request, "from") or end - DEFAULT_RANGE
    if start >= end:
        raise ValidationError({"from": ["must be before `to`"]})
    return start, end


def int_param(request: Request, name: str, *, default: int, low: int, high: int) -> int:
    raw = request.query_params.get(name)
    if raw in (None, ""):
        return default
    try:
        value = int(raw)
    except ValueError:
        raise ValidationError({name: [f"{raw!r} is not a whole number"]}) from None
    if not low <= value <= high:
        raise ValidationError({name: [f"must be from {low} to {high}"]})
    return value


class VesselReadView(APIView):
    """Reads under /vessels/<slug>/: the same rights as the vessel's fixes (view_fix and
    view_vessel, checked before the slug is looked up)."""

    queryset = Fix.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions, CanViewVessels]

    def vessel(self) -> Vessel:
        return vessel_by_slug(self.kwargs["slug"])


def _epoch_s(t: float) -> float | int:
    return int(t) if t == int(t) else round(t, 3)


def track_geojson(vessel: Vessel, start: dt.datetime, end: dt.datetime, result: Track) -> dict:
    # GeoJSON needs two positions per LineString: a lone fix is drawn as a zero-length line
    # (the same position twice, the same time twice), so one geometry holds the whole track.
    lines, times = [], []
    for segment in result.segments:
        if len(segment) == 1:
            segment = segment * 2
        lines.append(
            [[round(lon, COORD_DECIMALS), round(lat, COORD_DECIMALS)] for _t, lat, lon in segment]
        )
        times.append([_epoch_s(t) for t, _lat, _lon in segment])
    return {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "geometry": {"type": "MultiLineString", "coordinates": lines},
                "properties": {
                    "vessel": vessel.slug,
                    "from": start.isoformat(),
                    "to": end.isoformat(),
                    "fixes": result.fixes,
                    "points": result.points,
                    "gap_s": result.gap_s,
                    "times": times,
                },
            }
        ],
    }


def _json_response(body: Any, content_type: str = "application/json") -> HttpResponse:
    return HttpResponse(
        json.dumps(body, separators=(",", ":"), allow_nan=False), content_type=content_type
    )


@extend_schema(
    parameters=[
        *RANGE_PARAMETERS,
        OpenApiParameter(
            "max_points",
            {"type": "integer", "minimum": MIN_POINTS, "maximum": TRACK_MAX_POINTS},
            description=f"at most this many points (default {TRACK_DEFAULT_POINTS})",
        ),
    ],
    responses={(200, "application/geo+json"): TrackSerializer},
    tags=["operator"],
)
class VesselTrackView(VesselReadView):
    """The vessel's track in a range as GeoJSON, simplified on the server.

    One Feature: a MultiLineString with a line per run of reports, broken where the vessel was
    silent longer than `gap_s` (3 telemetry periods); a lone fix is a zero-length line. Its
    properties give the range, the fixes in it, the points returned, and `times`: the Unix
    seconds of every position, line by line, to find the fix under a click. Kept in any case:
    the first and last fix, the northmost/southmost/eastmost/westmost, the turns at the
    resolution of `max_points`.
    """

    def get(self, request: Request, slug: str) -> HttpResponse:
        start, end = range_params(request)
        max_points = int_param(
            request, "max_points", default=TRACK_DEFAULT_POINTS, low=MIN_POINTS,
            high=TRACK_MAX_POINTS,
        )  # fmt: skip
        vessel = self.vessel()
        result = track(vessel=vessel, start=start, end=end, max_points=max_points)
        return _json_response(
            track_geojson(vessel, start, end, result), content_type="application/geo+json"
        )


@extend_schema(
    parameters=[
        OpenApiParameter(
            "time",
            {"type": "string", "minLength": 1},
            required=True,
            description="ISO 8601 or Unix seconds",
        )
    ],
    responses={200: FixSerializer},
    tags=["operator"],
)
class VesselNearestFixView(VesselReadView):
    """The vessel's fix nearest in time to `time` (404 when the vessel has no fixes)."""

    def get(self, request: Request, slug: str) -> Response:
        if not request.query_params.get("time"):
            raise ValidationError({"time": ["is required (ISO 8601 or Unix seconds)"]})
        when = time_param(request, "time")
        assert when is not None
        fix = fix_nearest(vessel=self.vessel(), when=when)
        if fix is None:
            raise NotFound("This vessel has no fixes.")
        return Response(FixSerializer(fix).data)


def channel_meta(keys: list[str]) -> dict[str, tuple[str, str]]:
    """(label, unit) per reading key, from SensorChannel; the key itself and "" without one."""
    known = {c.key: (c.label, c.unit) for c in SensorChannel.objects.filter(key__in=keys)}
    return {key: known.get(key, (key, "")) for key in keys}


@extend_schema(
    parameters=[
        *RANGE_PARAMETERS,
        OpenApiParameter(
            "buckets",
            {"type": "integer", "minimum": 1, "maximum": SERIES_MAX_BUCKETS},
            description=f"at most this many buckets (default {SERIES_DEFAULT_BUCKETS})",
        ),
    ],
    responses={200: SeriesSerializer},
    tags=["operator"],
)
class VesselSeriesView(VesselReadView):
    """Battery and every reading seen in the range, downsampled for plots.

    Buckets of `bucket_s` seconds aligned to the Unix epoch; per channel each bucket's min,
    max and mean (null where the bucket has no data), so a spike survives any zoom. A reading
    with no SensorChannel is listed under its key with an empty unit.
    """

    def get(self, request: Request, slug: str) -> HttpResponse:
        start, end = range_params(request)
        buckets = int_param(
            request, "buckets", default=SERIES_DEFAULT_BUCKETS, low=1, high=SERIES_MAX_BUCKETS
        )
        vessel = self.vessel()
        result = series(vessel=vessel, start=start, end=end, max_buckets=buckets)
        readings = sorted(k for k in result.channels if k != BATTERY)
        meta = channel_meta(readings)
        channels: dict[str, Any] = {}
        if BATTERY in result.channels:
            channels["battery_v"] = {"label": "Battery", "unit": "V", **result.channels[BATTERY]}
        for key in readings:
            # A reading named like the battery field keeps its own series beside it.
            name = f"readings.{key}" if key == "battery_v" else key
            label, unit = meta[key]
            channels[name] = {"label": label, "unit": unit, **result.channels[key]}
        return _json_response(
            {
                "from": start.isoformat(),
                "to": end.isoformat(),
                "bucket_s": result.bucket_s,
                "t": result.starts,
                "channels": channels,
            }
        )


@extend_schema(
    parameters=[
        *RANGE_PARAMETERS,
        OpenApiParameter("format", str, enum=list(export.FORMATS), default="csv"),
    ],
    responses={
        (200, "text/csv"): OpenApiResponse(
            OpenApiTypes.STR, description=f"columns {export.CSV_HEADER.strip()}"
        ),
        (200, "application/geo+json"): OpenApiResponse(
            OpenApiTypes.OBJECT, description="a FeatureCollection: one Point feature per fix"
        ),
        (200, "application/gpx+xml"): OpenApiResponse(
            OpenApiTypes.STR, description="GPX 1.1: one trk, a trkseg per run of reports"
        ),
    },
    tags=["operator"],
)
class VesselTrackExportView(VesselReadView):
    """Every fix of the range at full resolution as CSV, GeoJSON or GPX 1.1, streamed."""

    def get(self, request: Request, slug: str) -> StreamingHttpResponse:
        fmt = request.query_params.get("format") or "csv"
        if fmt not in export.FORMATS:
            raise ValidationError({"format": [f"must be one of {', '.join(export.FORMATS)}"]})
        start, end = range_params(request)
        vessel = self.vessel()
        if fmt == "csv":
            chunks = export.csv_chunks(vessel.pk, start, end)
        elif fmt == "geojson":
            properties = {"vessel": vessel.slug, "from": start.isoformat(), "to": end.isoformat()}
            chunks = export.geojson_chunks(vessel.pk, start, end, properties)
        else:
            chunks = export.gpx_chunks(
                vessel.pk, start, end, name=vessel.name, gap_s=gap_seconds(vessel)
            )
        span = f"{start:%Y%m%dT%H%M%SZ}-{end:%Y%m%dT%H%M%SZ}"
        return export.streamed(chunks, fmt=fmt, filename=f"{slug}-{span}.{fmt}")
