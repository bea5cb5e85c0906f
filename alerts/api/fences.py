"""Operator API for fences: `/api/v1/fences/` (CRUD), `/api/v1/fences/import/` (a QGC `.plan`'s
geoFence section or GeoJSON) and `/api/v1/fences/<id>/send/` (queue the fence for a vessel's
autopilot). Writes go through vessels.fence_services and the fence command's service.

Here in alerts rather than beside the missions in vessels: sending writes a command, and
alerts sits above both vessels and commands (docs/architecture.md)."""

from __future__ import annotations

from typing import Any

from django.shortcuts import get_object_or_404
from drf_spectacular.utils import extend_schema, extend_schema_field
from rest_framework import serializers, status, viewsets
from rest_framework.decorators import action
from rest_framework.parsers import FormParser, MultiPartParser
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from alerts.api.serializers import who
from commands.api.missions import SendToVesselSerializer
from commands.api.operator import CommandSerializer
from commands.models import Command, Source
from commands.services import fence_send
from vessels import missionfiles
from vessels.api.fields import StrictCharField
from vessels.api.missions import STRICT_FIELDS, VesselSlugField
from vessels.api.parsers import JSONParser
from vessels.fence_services import fence_create, fence_delete, fence_import, fence_update
from vessels.fences import FENCE_MAX_VERTICES, RADIUS_MAX_M, RADIUS_MIN_M
from vessels.models import Fence
from vessels.permissions import CanViewVessels, ModelPermissions
from vessels.selectors import fences_visible_to

_POSITION = {
    "type": "array",
    "items": {"type": "number"},
    "minItems": 2,
    "maxItems": 3,
    "description": "[longitude, latitude]",
}
GEOMETRY_SCHEMA = {
    "oneOf": [
        {
            "type": "object",
            "description": "a polygon: one closed ring (last position = first), "
            f"3 to {FENCE_MAX_VERTICES} distinct vertices",
            "properties": {
                "type": {"type": "string", "enum": ["Polygon"]},
                "coordinates": {
                    "type": "array",
                    "minItems": 1,
                    "maxItems": 1,
                    "items": {"type": "array", "minItems": 4, "items": _POSITION},
                },
            },
            "required": ["type", "coordinates"],
        },
        {
            "type": "object",
            "description": "a circle's centre (with radius_m)",
            "properties": {
                "type": {"type": "string", "enum": ["Point"]},
                "coordinates": _POSITION,
            },
            "required": ["type", "coordinates"],
        },
    ],
    "description": "GeoJSON (RFC 7946), [longitude, latitude]",
}


@extend_schema_field(GEOMETRY_SCHEMA)
class GeometryField(serializers.JSONField):
    """A GeoJSON object, for vessels.fences.clean to judge (via the model's clean())."""

    def to_internal_value(self, data: Any) -> Any:
        if not isinstance(data, dict):
            raise serializers.ValidationError("must be a GeoJSON object (Polygon or Point)")
        return super().to_internal_value(data)


class FenceSerializer(serializers.ModelSerializer):
    serializer_field_mapping = STRICT_FIELDS
    vessel = VesselSlugField(
        slug_field="slug", allow_null=True, required=False, help_text="null: every vessel"
    )
    geometry = GeometryField()
    radius_m = serializers.FloatField(
        required=False, allow_null=True, min_value=RADIUS_MIN_M, max_value=RADIUS_MAX_M,
        help_text="a circle's radius (metres), with a Point; null for a Polygon",
    )  # fmt: skip
    shape = serializers.CharField(
        read_only=True, help_text='"polygon, 5 vertices", "circle, 250 m"'
    )

    class Meta:
        model = Fence
        fields = [
            "id", "name", "vessel", "inclusion", "geometry", "radius_m", "notes", "shape",
            "created_at", "updated_at",
        ]  # fmt: skip
        read_only_fields = ["id", "created_at", "updated_at"]

    def create(self, validated_data: dict[str, Any]) -> Fence:
        return fence_create(**validated_data, **who(self.context["request"]))

    def update(self, instance: Fence, validated_data: dict[str, Any]) -> Fence:
        return fence_update(fence=instance, fields=validated_data, **who(self.context["request"]))


class FenceImportSerializer(serializers.Serializer):
    file = serializers.FileField(help_text="a QGroundControl .plan (its geoFence) or GeoJSON")
    format = serializers.ChoiceField(
        ["plan", "geojson"], required=False, help_text="default: from the file's name and content"
    )
    vessel = VesselSlugField(
        slug_field="slug", required=False, allow_null=True, help_text="null: every vessel"
    )
    name = StrictCharField(
        max_length=90, required=False, allow_blank=True,
        help_text="the fences' name when the file names none (default: the file's name)",
    )  # fmt: skip


@extend_schema(tags=["operator"])
class FenceViewSet(viewsets.ModelViewSet):
    """Fences: polygons and circles a vessel must stay inside (inclusion) or outside
    (exclusion). A fence with no vessel is every vessel's. Fence alert rules watch them on
    the shore; `send` loads one into an ArduPilot boat's autopilot."""

    serializer_class = FenceSerializer
    queryset = Fence.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions]
    pagination_class = None
    parser_classes = [JSONParser]
    http_method_names = ["get", "post", "patch", "delete", "head", "options"]

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        return fences_visible_to(self.request.user)

    def perform_destroy(self, instance: Fence) -> None:
        fence_delete(fence=instance, **who(self.request))

    @extend_schema(
        request={"multipart/form-data": FenceImportSerializer},
        responses={201: FenceSerializer(many=True)},
    )
    @action(
        detail=False,
        methods=["post"],
        url_path="import",
        parser_classes=[MultiPartParser, FormParser],
    )
    def import_file(self, request: Request) -> Response:
        """Import every fence of a QGroundControl `.plan` (its `geoFence` polygons and
        circles) or a GeoJSON file (Polygons, MultiPolygons, Points with `radius_m`): all of
        them, or none with a 400 naming each problem."""
        incoming = FenceImportSerializer(data=request.data, context={"request": request})
        incoming.is_valid(raise_exception=True)
        data = incoming.validated_data
        upload = data["file"]
        missionfiles.check_size(upload.size)
        created = fence_import(
            content=upload.read(),
            format=data.get("format"),
            vessel=data.get("vessel"),
            name=data.get("name", ""),
            filename=upload.name or "",
            **who(request),
        )
        body = FenceSerializer(created, many=True, context=self.get_serializer_context()).data
        return Response(body, status=status.HTTP_201_CREATED)


class FenceSendSerializer(SendToVesselSerializer):
    vessel = serializers.SlugField(
        required=False, help_text="slug of the vessel to load it (default: the fence's own)"
    )


class FenceSendView(APIView):
    queryset = Command.objects.none()  # sending needs commands.add_command
    permission_classes = [ModelPermissions, CanViewVessels]

    @extend_schema(
        request=FenceSendSerializer, responses={201: CommandSerializer}, tags=["operator"]
    )
    def post(self, request: Request, pk: int) -> Response:
        """Queue the fence as a `fence` command for its vessel (or `vessel`): the boat's edge
        client loads it into the autopilot and enables it. 400 says why not."""
        fence = get_object_or_404(fences_visible_to(request.user), pk=pk)
        incoming = FenceSendSerializer(data=request.data)
        incoming.is_valid(raise_exception=True)
        # fence_send refuses another boat's fence, a fence with no vessel named and a vessel
        # without an autopilot fence (CommandError: a 400 naming the field).
        command = fence_send(
            fence=fence,
            vessel=incoming.validated_data.get("vessel"),
            created_by=request.user.get_username(),
            source=Source.API,
        )
        return Response(CommandSerializer(command).data, status=status.HTTP_201_CREATED)
