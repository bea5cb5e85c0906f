"""Serializers of the alerts API. A rule's limits are `min` and `max` on the wire (the model's
`minimum` and `maximum`); a rule's checks by kind are the service's (alerts.services.rules),
whose field errors come back under the wire's names."""

from __future__ import annotations

from typing import Any

from django.core.exceptions import ValidationError as DjangoValidationError
from django.core.validators import EmailValidator, RegexValidator, URLValidator
from drf_spectacular.utils import extend_schema_field
from rest_framework import serializers

from alerts.models import Alert, AlertRule, ChannelKind, NotificationChannel
from alerts.services.rules import alert_rule_create, alert_rule_update
from vessels.api.fields import StrictCharField
from vessels.api.missions import STRICT_FIELDS, VesselSlugField
from vessels.models import Fence, VesselKind
from vessels.selectors import fences_visible_to

# The model's names for what the wire calls min and max.
WIRE_NAMES = {"minimum": "min", "maximum": "max"}
# E.164: a plus, then up to 15 digits, the first not 0 (ITU-T E.164 §6.2.1).
E164 = r"^\+[1-9][0-9]{6,14}$"


def who(request: Any) -> dict[str, Any]:
    """Who is acting and from where, for the services' audit entries."""
    return {"by": request.user.get_username(), "via": "api", "ip": request.META.get("REMOTE_ADDR")}


def on_the_wire(exc: DjangoValidationError) -> serializers.ValidationError:
    detail = exc.message_dict if hasattr(exc, "error_dict") else {"non_field_errors": exc.messages}
    return serializers.ValidationError({WIRE_NAMES.get(k, k): v for k, v in detail.items()})


@extend_schema_field(
    {
        "type": "string",
        "nullable": True,
        "enum": [*VesselKind.values, None],
        "description": "null: every kind",
    }  # fmt: skip
)
class VesselKindField(serializers.ChoiceField):
    """A vessel kind or null (the model's blank: every kind)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(VesselKind.choices, allow_null=True, required=False, **kwargs)

    def validate_empty_values(self, data: Any) -> tuple[bool, Any]:
        # null is the model's blank ("": every kind); DRF would pass None on unvalidated.
        if data is None:
            return True, ""
        return super().validate_empty_values(data)

    def to_representation(self, value: str) -> str | None:
        return value or None


class FenceChoiceField(serializers.PrimaryKeyRelatedField):
    """A fence by id, among those the operator may see."""

    def get_queryset(self) -> Any:
        request = self.context.get("request")
        return fences_visible_to(request.user) if request else Fence.objects.none()


class AlertRuleSerializer(serializers.ModelSerializer):
    serializer_field_mapping = STRICT_FIELDS
    vessel = VesselSlugField(
        slug_field="slug", allow_null=True, required=False, help_text="null: every vessel"
    )
    vessel_kind = VesselKindField()
    reading = StrictCharField(
        max_length=50, required=False, allow_blank=True, help_text="a reading key, for reading"
    )
    min = serializers.FloatField(
        source="minimum", required=False, allow_null=True, help_text="for reading"
    )
    max = serializers.FloatField(
        source="maximum", required=False, allow_null=True, help_text="for reading"
    )
    fence = FenceChoiceField(required=False, allow_null=True, help_text="a fence's id, for fence")
    channels = serializers.PrimaryKeyRelatedField(
        many=True, required=False, queryset=NotificationChannel.objects.all(),
        help_text="ids of the notification channels told about this rule's alerts",
    )  # fmt: skip

    class Meta:
        model = AlertRule
        fields = [
            "id", "name", "vessel", "vessel_kind", "kind", "threshold", "reading", "min", "max",
            "fence", "channels", "active", "created_at", "updated_at",
        ]  # fmt: skip
        read_only_fields = ["id", "created_at", "updated_at"]
        extra_kwargs = {
            "threshold": {
                "help_text": "periods for overdue, volts for battery, hours for endurance"
            },
        }

    def create(self, validated_data: dict[str, Any]) -> AlertRule:
        channels = validated_data.pop("channels", [])
        try:
            return alert_rule_create(
                fields=validated_data, channels=channels, **who(self.context["request"])
            )
        except DjangoValidationError as exc:
            raise on_the_wire(exc) from None

    def update(self, instance: AlertRule, validated_data: dict[str, Any]) -> AlertRule:
        channels = validated_data.pop("channels", None)
        try:
            return alert_rule_update(
                rule=instance, fields=validated_data, channels=channels,
                **who(self.context["request"]),
            )  # fmt: skip
        except DjangoValidationError as exc:
            raise on_the_wire(exc) from None


class AlertSerializer(serializers.ModelSerializer):
    vessel = serializers.SlugRelatedField(slug_field="slug", read_only=True)
    rule_name = serializers.CharField(source="rule.name", read_only=True)

    class Meta:
        model = Alert
        fields = [
            "id", "vessel", "rule", "rule_name", "kind", "subject", "state", "opened_at",
            "acknowledged_at", "acknowledged_by", "resolved_at", "detail", "value",
        ]  # fmt: skip
        read_only_fields = fields


class ChannelSerializer(serializers.ModelSerializer):
    has_secret = serializers.SerializerMethodField(help_text="a webhook signs with a secret")

    class Meta:
        model = NotificationChannel
        fields = ["id", "name", "kind", "target", "active", "has_secret", "created_at"]
        read_only_fields = fields

    def get_has_secret(self, channel: NotificationChannel) -> bool:
        return bool(channel.secret)


class ChannelCreatedSerializer(ChannelSerializer):
    secret = serializers.CharField(
        help_text='a webhook\'s HMAC-SHA256 key: shown here once, never again ("" for others)'
    )

    class Meta(ChannelSerializer.Meta):
        fields = [*ChannelSerializer.Meta.fields, "secret"]
        read_only_fields = fields


TARGET_CHECKS = {
    ChannelKind.EMAIL: (EmailValidator(), "an e-mail address"),
    ChannelKind.WEBHOOK: (URLValidator(schemes=["http", "https"]), "an http(s) URL"),
    ChannelKind.SMS: (
        RegexValidator(E164),
        "a phone number in international form (+61…)",
    ),
}


class ChannelCreateSerializer(serializers.Serializer):
    name = StrictCharField(max_length=100)
    kind = serializers.ChoiceField(ChannelKind.choices)
    target = StrictCharField(max_length=500, help_text="e-mail address, phone number or URL")
    secret = StrictCharField(
        max_length=128, min_length=16, required=False,
        help_text="a webhook's signing key (default: one generated, returned once)",
    )  # fmt: skip

    def validate(self, attrs: dict[str, Any]) -> dict[str, Any]:
        check, what = TARGET_CHECKS[attrs["kind"]]
        try:
            check(attrs["target"])
        except DjangoValidationError:
            raise serializers.ValidationError(
                {"target": [f"a {attrs['kind']} channel's target is {what}"]}
            ) from None
        if "secret" in attrs and attrs["kind"] != ChannelKind.WEBHOOK:
            raise serializers.ValidationError({"secret": ["only a webhook has a secret"]})
        return attrs
