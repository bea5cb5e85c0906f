"""The audit log as the operator API shows it."""

from __future__ import annotations

from rest_framework import serializers

from audit.models import AuditEntry


class AuditEntrySerializer(serializers.ModelSerializer):
    class Meta:
        model = AuditEntry
        fields = [
            "id",
            "at",
            "actor",
            "actor_kind",
            "via",
            "ip",
            "action",
            "subject_type",
            "subject_id",
            "subject",
            "vessel",
            "detail",
        ]
        read_only_fields = fields
