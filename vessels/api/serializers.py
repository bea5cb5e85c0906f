from __future__ import annotations

from typing import Any

from django.utils import timezone
from drf_spectacular.extensions import OpenApiSerializerExtension
from rest_framework import serializers

from vessels.models import Vessel


class VesselSerializer(serializers.ModelSerializer):
    status = serializers.SerializerMethodField()

    class Meta:
        model = Vessel
        fields = [
            "slug",
            "name",
            "kind",
            "active",
            "telemetry_period_s",
            "cruise_speed_mps",
            "move_to_max_m",
            "imei",
            "sms_number",
            "status",
            "last_seen_at",
            "last_fix_at",
            "last_fix",
            "notes",
        ]
        read_only_fields = fields

    def get_status(self, vessel: Vessel) -> str:
        return vessel.status(timezone.now())


class VesselUpdateSerializer(serializers.ModelSerializer):
    """What an operator may change through the API (PATCH); anything else is refused by name
    rather than silently ignored."""

    class Meta:
        model = Vessel
        fields = ["move_to_max_m", "imei", "sms_number"]

    def validate_imei(self, value: str | None) -> str | None:
        return value or None  # "" clears it, as null does: unique, so never stored blank

    def validate(self, attrs: dict[str, Any]) -> dict[str, Any]:
        given = self.initial_data if isinstance(self.initial_data, dict) else {}
        unknown = sorted(set(given) - set(self.Meta.fields))
        if unknown:
            raise serializers.ValidationError(
                {unknown[0]: [f"cannot be changed here (only {', '.join(self.Meta.fields)})"]}
            )
        return attrs


class VesselUpdateSchema(OpenApiSerializerExtension):
    """The PATCH body's schema closes its object, as validate() does: any other field is a
    400, so a client (or schemathesis) reading the schema knows not to send one."""

    target_class = VesselUpdateSerializer

    def map_serializer(self, auto_schema: Any, direction: str) -> dict[str, Any]:
        schema = auto_schema._map_serializer(self.target, direction, bypass_extensions=True)
        return {**schema, "additionalProperties": False}


class _LastFixSerializer(serializers.Serializer):
    time = serializers.DateTimeField()
    lat = serializers.FloatField()
    lon = serializers.FloatField()
    heading_deg = serializers.FloatField(allow_null=True)
    speed_mps = serializers.FloatField(allow_null=True)
    battery_v = serializers.FloatField(allow_null=True)
    readings = serializers.DictField(child=serializers.FloatField(), allow_null=True)


class _FleetVesselSerializer(serializers.Serializer):
    slug = serializers.SlugField()
    name = serializers.CharField()
    kind = serializers.CharField()
    status = serializers.ChoiceField(choices=["reporting", "overdue", "never seen"])
    telemetry_period_s = serializers.IntegerField()
    last_seen_at = serializers.DateTimeField(allow_null=True)
    last_fix = _LastFixSerializer(allow_null=True)
    admin_url = serializers.CharField()


class FleetSerializer(serializers.Serializer):
    """The fleet map's poll (documentation only: the view writes the JSON itself)."""

    server_time = serializers.DateTimeField()
    vessels = _FleetVesselSerializer(many=True)
