from __future__ import annotations

from django.utils import timezone
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
            "status",
            "last_seen_at",
            "last_fix_at",
            "last_fix",
            "notes",
        ]
        read_only_fields = fields

    def get_status(self, vessel: Vessel) -> str:
        return vessel.status(timezone.now())
