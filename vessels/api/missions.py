"""Operator API for missions (docs/missions.md): `/api/v1/missions/` CRUD with the items nested, the
route's legs and totals, file import and export. Writes go through vessels.services.

Sending a mission queues a command, which the commands app owns: `POST
/api/v1/missions/<id>/send/` lives in commands.api.missions.
"""

from __future__ import annotations

from typing import Any

from django.db import models
from django.http import HttpResponse
from drf_spectacular.extensions import OpenApiSerializerExtension
from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import (
    OpenApiParameter,
    OpenApiResponse,
    extend_schema,
    extend_schema_field,
)
from rest_framework import exceptions, serializers, status, viewsets
from rest_framework.decorators import action
from rest_framework.exceptions import ValidationError
from rest_framework.parsers import FormParser, MultiPartParser
from rest_framework.request import Request
from rest_framework.response import Response

from vessels import missionfiles
from vessels.api.boat import JsonOnly
from vessels.api.fields import StrictCharField, StrictFloatField
from vessels.api.parsers import JSONParser
from vessels.errors import MissionFileError
from vessels.missions import MISSION_MAX_ITEMS
from vessels.models import Mission, MissionItem, Vessel
from vessels.permissions import ModelPermissions
from vessels.selectors import missions_visible_to
from vessels.services import (
    mission_delete,
    mission_export,
    mission_import,
    mission_route_problems,
    mission_summary,
    mission_write,
)

# The model's fields as the JSON types the schema gives them: no "0" for 0, no 1.0 for true.
STRICT_FIELDS = {
    **serializers.ModelSerializer.serializer_field_mapping,
    models.CharField: StrictCharField,
    models.TextField: StrictCharField,
    models.FloatField: StrictFloatField,
}


class MissionItemSerializer(serializers.ModelSerializer):
    serializer_field_mapping = STRICT_FIELDS

    class Meta:
        model = MissionItem
        fields = ["seq", "lat", "lon", "hold_s", "radius_m", "speed_mps"]
        read_only_fields = ["seq"]  # the order of the list is the order of the mission


@extend_schema_field({"oneOf": [{"type": "integer"}, {"type": "string", "enum": ["home"]}]})
class LegEndField(serializers.Field):
    """Where a leg ends: an item's seq, or "home" for the return leg."""

    def to_representation(self, value: int | str) -> int | str:
        return value


class LegSerializer(serializers.Serializer):
    # "from" is a Python keyword: declared below under its wire name.
    to = LegEndField(help_text='the seq of the item the leg ends at, or "home"')
    distance_m = serializers.FloatField()
    bearing_deg = serializers.FloatField()
    speed_mps = serializers.FloatField()
    time_s = serializers.FloatField()

    def get_fields(self) -> dict[str, Any]:
        start = serializers.IntegerField(help_text="seq of the item the leg starts at")
        return {"from": start, **super().get_fields()}


@extend_schema_field({"type": "string", "nullable": True, "description": "vessel slug"})
class VesselSlugField(serializers.SlugRelatedField):
    """A vessel by slug, among those the operator may see (none without `view_vessel`)."""

    def get_queryset(self) -> Any:
        request = self.context.get("request")
        if request is None or not request.user.has_perm("vessels.view_vessel"):
            return Vessel.objects.none()
        return Vessel.objects.all()


class MissionSerializer(serializers.ModelSerializer):
    serializer_field_mapping = STRICT_FIELDS
    vessel = VesselSlugField(
        slug_field="slug", allow_null=True, required=False, help_text="null: a template"
    )
    items = MissionItemSerializer(many=True, required=False, max_length=MISSION_MAX_ITEMS)
    legs = serializers.SerializerMethodField()
    total_m = serializers.SerializerMethodField(help_text="metres along every leg")
    total_s = serializers.SerializerMethodField(
        help_text="seconds: legs at the vessel's cruise speed (or the items' own) plus holds"
    )
    problems = serializers.SerializerMethodField(
        help_text="the route checks a send would fail (a leg over MISSION_MAX_LEG_M, …); "
        "[] when none"
    )

    class Meta:
        model = Mission
        fields = [
            "id",
            "name",
            "vessel",
            "end",
            "home_lat",
            "home_lon",
            "notes",
            "items",
            "legs",
            "total_m",
            "total_s",
            "problems",
            "created_at",
            "updated_at",
        ]
        read_only_fields = ["id", "created_at", "updated_at"]

    def _summary(self, mission: Mission) -> Any:
        cache = self.context.setdefault("_summaries", {})
        if mission.pk not in cache:
            cache[mission.pk] = mission_summary(mission=mission)
        return cache[mission.pk]

    @extend_schema_field(LegSerializer(many=True))
    def get_legs(self, mission: Mission) -> list[dict[str, Any]]:
        return [leg.as_dict() for leg in self._summary(mission).legs]

    def get_total_m(self, mission: Mission) -> float:
        return self._summary(mission).total_m

    def get_total_s(self, mission: Mission) -> float:
        return self._summary(mission).total_s

    def get_problems(self, mission: Mission) -> list[str]:
        return mission_route_problems(mission=mission)

    def create(self, validated_data: dict[str, Any]) -> Mission:
        items = validated_data.pop("items", [])
        return mission_write(mission=Mission(), fields=validated_data, items=items)

    def update(self, instance: Mission, validated_data: dict[str, Any]) -> Mission:
        items = validated_data.pop("items", None)
        mission = mission_write(mission=instance, fields=validated_data, items=items)
        return Mission.objects.prefetch_related("items").get(pk=mission.pk)


# A home is both coordinates or neither (Mission.clean): the rule of a whole mission, so of
# a POST or PUT body; a PATCH is checked on the mission as the update leaves it.
_HAS_HOME_LAT = {"required": ["home_lat"], "properties": {"home_lat": {"type": "number"}}}
_HAS_HOME_LON = {"required": ["home_lon"], "properties": {"home_lon": {"type": "number"}}}
HOME_BOTH_OR_NEITHER = [
    {"description": "a home: both coordinates", "allOf": [_HAS_HOME_LAT, _HAS_HOME_LON]},
    {
        "description": "no home: neither coordinate (both absent or null)",
        "not": {"anyOf": [_HAS_HOME_LAT, _HAS_HOME_LON]},
    },
]


class MissionSchema(OpenApiSerializerExtension):
    """The mission's request schema with the home rule, which no single field can state."""

    target_class = MissionSerializer

    def map_serializer(self, auto_schema: Any, direction: str) -> dict[str, Any]:
        schema = auto_schema._map_serializer(self.target, direction, bypass_extensions=True)
        if direction == "request":
            schema["anyOf"] = HOME_BOTH_OR_NEITHER
        return schema


class MissionImportSerializer(serializers.Serializer):
    file = serializers.FileField(help_text="a .plan, .waypoints or GeoJSON file")
    format = serializers.ChoiceField(
        missionfiles.FORMATS, required=False, help_text="default: from the file's name and content"
    )
    vessel = VesselSlugField(slug_field="slug", required=False, allow_null=True)
    name = StrictCharField(max_length=100, required=False, allow_blank=True)
    skip_unsupported = serializers.BooleanField(
        required=False,
        default=False,
        help_text="import the rest when some items are unsupported (listed in `skipped`)",
    )


class ImportedMissionSerializer(MissionSerializer):
    skipped = serializers.SerializerMethodField(
        help_text="items of the file left out (only with skip_unsupported)"
    )

    class Meta(MissionSerializer.Meta):
        fields = [*MissionSerializer.Meta.fields, "skipped"]

    def get_skipped(self, mission: Mission) -> list[str]:
        return self.context.get("skipped", [])


_EXPORT_TYPES = {
    "plan": "application/json",
    "waypoints": "text/plain",
    "geojson": "application/geo+json",
}

# One description for the three content types (OpenAPI has one per status code).
_EXPORT_DESCRIPTION = (
    "a file by `format`: `plan` a QGroundControl .plan (a JSON object), `waypoints` a Mission "
    "Planner .waypoints (text), `geojson` a FeatureCollection"
)


class UploadTooLarge(exceptions.APIException):
    status_code = status.HTTP_413_REQUEST_ENTITY_TOO_LARGE
    default_code = "too_large"


@extend_schema(tags=["operator"])
class MissionViewSet(viewsets.ModelViewSet):
    """Missions (routes for a vessel, or templates) with their items in order, the legs between
    them and the totals at the vessel's cruise speed. Writing `items` replaces them all."""

    serializer_class = MissionSerializer
    queryset = Mission.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions]
    pagination_class = None
    parser_classes = [JSONParser]

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        return missions_visible_to(self.request.user)

    def initial(self, request: Request, *args: Any, **kwargs: Any) -> None:
        # Before authentication: the session's CSRF check reads the multipart body.
        if self.action == "import_file":
            try:
                missionfiles.check_request_size(request.META.get("CONTENT_LENGTH"))
            except MissionFileError as exc:
                raise UploadTooLarge(exc.message) from None
        super().initial(request, *args, **kwargs)

    def perform_destroy(self, instance: Mission) -> None:
        mission_delete(mission=instance)

    @extend_schema(
        request={"multipart/form-data": MissionImportSerializer},
        responses={201: ImportedMissionSerializer},
    )
    @action(
        detail=False,
        methods=["post"],
        url_path="import",
        parser_classes=[MultiPartParser, FormParser],
    )
    def import_file(self, request: Request) -> Response:
        """Import a QGroundControl `.plan`, Mission Planner `.waypoints` or GeoJSON file.

        400 names every item the mission cannot hold (by number and MAV_CMD name) unless
        `skip_unsupported` is set; then those items are listed in `skipped`."""
        incoming = MissionImportSerializer(data=request.data, context={"request": request})
        incoming.is_valid(raise_exception=True)
        data = incoming.validated_data
        upload = data["file"]
        missionfiles.check_size(upload.size)
        mission, skipped = mission_import(
            content=upload.read(),
            filename=upload.name or "",
            format=data.get("format"),
            vessel=data.get("vessel"),
            name=data.get("name", ""),
            skip_unsupported=data["skip_unsupported"],
        )
        mission = self.get_queryset().get(pk=mission.pk)
        context = {**self.get_serializer_context(), "skipped": skipped}
        body = ImportedMissionSerializer(mission, context=context).data
        return Response(body, status=status.HTTP_201_CREATED)

    @extend_schema(
        parameters=[
            OpenApiParameter("format", str, enum=list(missionfiles.FORMATS), required=True)
        ],
        responses={
            (200, _EXPORT_TYPES["plan"]): OpenApiResponse(
                OpenApiTypes.OBJECT, description=_EXPORT_DESCRIPTION
            ),
            (200, _EXPORT_TYPES["waypoints"]): OpenApiResponse(
                OpenApiTypes.STR, description=_EXPORT_DESCRIPTION
            ),
            (200, _EXPORT_TYPES["geojson"]): OpenApiResponse(
                OpenApiTypes.OBJECT, description=_EXPORT_DESCRIPTION
            ),
        },
    )
    @action(detail=True, methods=["get"], content_negotiation_class=JsonOnly)
    def export(self, request: Request, pk: str | None = None) -> HttpResponse:
        """The mission as a file: `?format=plan` (QGroundControl), `waypoints` (Mission
        Planner) or `geojson`, as an attachment."""
        mission = self.get_object()
        fmt = request.query_params.get("format", "")
        if fmt not in missionfiles.FORMATS:
            raise ValidationError({"format": [f"one of {', '.join(missionfiles.FORMATS)}"]})
        content, content_type, filename = mission_export(mission=mission, format=fmt)
        response = HttpResponse(content, content_type=content_type)
        response["Content-Disposition"] = f'attachment; filename="{filename}"'
        return response
