"""``GET /api/v1/fleet/overlays/``: the fleet map's trails, running missions and fences
(fleet.console), and ``GET /api/v1/fleet/alerts/``: its open alerts (fleet.console_alerts);
both with an ETag like the fleet poll's."""

from __future__ import annotations

import datetime as dt
import hashlib
import json

from django.conf import settings
from django.http import HttpResponse
from drf_spectacular.utils import OpenApiParameter, OpenApiResponse, extend_schema
from rest_framework import serializers
from rest_framework.request import Request
from rest_framework.views import APIView

from alerts.models import Alert
from fleet.console import TRAIL_MAX_MINUTES, fleet_overlays
from fleet.console_alerts import active_alerts, fence_entries
from telemetry.api.maps import int_param
from vessels.api.conditional import etag_matches
from vessels.models import Vessel
from vessels.permissions import CanViewVessels, ModelPermissions
from vessels.selectors import fleet_vessels


class _TrailSerializer(serializers.Serializer):
    gap_s = serializers.FloatField()
    lines = serializers.ListField(
        child=serializers.ListField(child=serializers.ListField(child=serializers.FloatField()))
    )


class _MissionItemSerializer(serializers.Serializer):
    lat = serializers.FloatField()
    lon = serializers.FloatField()


class _MissionSerializer(serializers.Serializer):
    uid = serializers.UUIDField()
    status = serializers.CharField()
    created_at = serializers.DateTimeField()
    acknowledged_at = serializers.DateTimeField(allow_null=True)
    mission_id = serializers.IntegerField(allow_null=True)
    end = serializers.CharField()
    items = _MissionItemSerializer(many=True)


class _FenceSerializer(serializers.Serializer):
    id = serializers.IntegerField()
    name = serializers.CharField()
    vessel = serializers.SlugField(allow_null=True, help_text="null: every vessel's")
    inclusion = serializers.BooleanField()
    geometry = serializers.JSONField(help_text="GeoJSON Polygon, or a Point (with radius_m)")
    radius_m = serializers.FloatField(allow_null=True)


class _EnduranceSerializer(serializers.Serializer):
    hours = serializers.FloatField(
        allow_null=True, help_text="hours to the empty voltage; null unless falling"
    )
    text = serializers.CharField(help_text="as the vessel's panel says it")


class _OverlaySerializer(serializers.Serializer):
    slug = serializers.SlugField()
    trail = _TrailSerializer(allow_null=True)
    mission = _MissionSerializer(allow_null=True)
    endurance = _EnduranceSerializer(
        allow_null=True, help_text="battery endurance, day over day (null without view_fix)"
    )


class OverlaysSerializer(serializers.Serializer):
    """The fleet map's overlays (documentation only: the view writes the JSON itself)."""

    server_time = serializers.DateTimeField()
    minutes = serializers.IntegerField()
    trails = serializers.BooleanField(
        help_text="the caller may see fixes (else every trail is null)"
    )
    missions = serializers.BooleanField(
        help_text="the caller may see commands (else every mission is null)"
    )
    vessels = _OverlaySerializer(many=True)
    fences = _FenceSerializer(
        many=True, allow_null=True, help_text="null without the right to see fences"
    )


@extend_schema(
    parameters=[
        OpenApiParameter(
            "minutes",
            {"type": "integer", "minimum": 0, "maximum": TRAIL_MAX_MINUTES},
            description="trail length (default FLEET_MAP_TRAIL_MINUTES; 0 = no trails)",
        ),
        OpenApiParameter("If-None-Match", str, OpenApiParameter.HEADER),
    ],
    responses={200: OverlaysSerializer, 304: OpenApiResponse(description="Not modified")},
    tags=["operator"],
)
class FleetOverlaysView(APIView):
    """Every active vessel's trail of the last `minutes` and its running mission.

    A trail is lines of `[t, lat, lon]` (t in Unix seconds, oldest first), broken where the
    vessel was silent longer than `gap_s`; simplified to a few hundred points. The mission is
    the vessel's newest acknowledged `mission` command (else its newest queued or sent one):
    its waypoints in order and how it ends; the waypoint the vessel is heading to is in its
    fixes' readings (`waypoint` of `waypoints`). The endurance is the battery's, as endurance
    alert rules judge it (read at most every 5 minutes). The fences of the fleet's vessels and those
    every vessel keeps come with them. Poll it seldom: the fleet poll's last fixes extend the
    trails in between.
    """

    queryset = Vessel.objects.none()  # for the model permission check (view_vessel)
    permission_classes = [ModelPermissions]

    def get(self, request: Request) -> HttpResponse:
        minutes = int_param(
            request, "minutes", default=settings.FLEET_MAP_TRAIL_MINUTES, low=0,
            high=TRAIL_MAX_MINUTES,
        )  # fmt: skip
        user = request.user
        trails, missions = (
            user.has_perm("telemetry.view_fix"),
            user.has_perm("commands.view_command"),
        )
        now = dt.datetime.now(dt.UTC)
        fleet = list(fleet_vessels())
        vessels = fleet_overlays(fleet, now=now, minutes=minutes, trails=trails, missions=missions)
        fences = fence_entries(fleet) if user.has_perm("vessels.view_fence") else None
        head = {"minutes": minutes, "trails": trails, "missions": missions, "fences": fences}
        encoded = json.dumps({**head, "vessels": vessels}, separators=(",", ":"), sort_keys=True)
        etag = '"' + hashlib.sha256(encoded.encode()).hexdigest()[:32] + '"'
        if etag_matches(request.headers.get("If-None-Match"), etag):
            response = HttpResponse(status=304)
        else:
            body = '{"server_time":"%s",%s' % (now.isoformat(), encoded[1:])  # noqa: UP031
            response = HttpResponse(body, content_type="application/json")
        response["ETag"] = etag
        response["Cache-Control"] = "private, no-cache"
        return response


class _FleetAlertSerializer(serializers.Serializer):
    id = serializers.IntegerField()
    vessel = serializers.SlugField()
    rule = serializers.CharField()
    kind = serializers.CharField()
    state = serializers.ChoiceField(choices=["open", "acknowledged"])
    opened_at = serializers.DateTimeField()
    acknowledged_at = serializers.DateTimeField(allow_null=True)
    acknowledged_by = serializers.CharField(allow_blank=True)
    detail = serializers.CharField(allow_blank=True)
    value = serializers.FloatField(allow_null=True)


class FleetAlertsSerializer(serializers.Serializer):
    """The fleet map's open alerts (documentation only: the view writes the JSON itself)."""

    server_time = serializers.DateTimeField()
    alerts = _FleetAlertSerializer(many=True)


@extend_schema(
    parameters=[OpenApiParameter("If-None-Match", str, OpenApiParameter.HEADER)],
    responses={200: FleetAlertsSerializer, 304: OpenApiResponse(description="Not modified")},
    tags=["operator"],
)
class FleetAlertsView(APIView):
    """The active fleet's open and acknowledged alerts, newest first, with an ETag: the fleet
    map polls it as often as the fleet, and badges each vessel with its open alerts."""

    queryset = Alert.objects.none()  # for the model permission check (view_alert)
    permission_classes = [ModelPermissions, CanViewVessels]

    def get(self, request: Request) -> HttpResponse:
        now = dt.datetime.now(dt.UTC)
        encoded = json.dumps(active_alerts(fleet_vessels()), separators=(",", ":"), sort_keys=True)
        etag = '"' + hashlib.sha256(encoded.encode()).hexdigest()[:32] + '"'
        if etag_matches(request.headers.get("If-None-Match"), etag):
            response = HttpResponse(status=304)
        else:
            body = '{"server_time":"%s","alerts":%s}' % (now.isoformat(), encoded)  # noqa: UP031
            response = HttpResponse(body, content_type="application/json")
        response["ETag"] = etag
        response["Cache-Control"] = "private, no-cache"
        return response
