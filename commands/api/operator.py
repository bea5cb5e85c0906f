"""Operator command API: list and create a vessel's commands, cancel one."""

from __future__ import annotations

from typing import Any

from drf_spectacular.utils import extend_schema, extend_schema_field
from rest_framework import generics, serializers, status
from rest_framework.pagination import CursorPagination
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from commands.models import Command, CommandEvent, Relay, Source
from commands.selectors import command_by_uid
from commands.services import command_cancel, command_enqueue
from vessels.api.fields import StrictBooleanField, StrictCharField
from vessels.permissions import CanViewVessels, ChangeModelPermissions, ModelPermissions
from vessels.selectors import vessel_by_slug


class CommandEventSerializer(serializers.ModelSerializer):
    class Meta:
        model = CommandEvent
        fields = ["at", "from_status", "to_status", "actor", "detail"]


class CommandSerializer(serializers.ModelSerializer):
    vessel = serializers.SlugRelatedField(slug_field="slug", read_only=True)
    events = CommandEventSerializer(many=True, read_only=True)
    # Its own field: the model's choices leave out "" (not relayed), which the schema must list.
    relay = serializers.ChoiceField(
        [("", "not relayed"), *Relay.choices],
        allow_blank=True,
        read_only=True,
        help_text="how the shore relayed it beside HTTP (docs/links.md#routing-per-vessel): "
        '"" not relayed, sms, sbd, or none (no link could carry it)',
    )

    class Meta:
        model = Command
        fields = [
            "uid",
            "vessel",
            "kind",
            "params",
            "status",
            "source",
            "created_by",
            "created_at",
            "expires_at",
            "sent_at",
            "acknowledged_at",
            "finished_at",
            "result_detail",
            "urgent",
            "relay",
            "relayed_at",
            "events",
        ]
        read_only_fields = fields


# What an API client may say it is: a script (api) or the fleet map's buttons (map). The
# admin, an SMS and a vessel have their own ways in; a client cannot pass for them.
API_SOURCES = (Source.API, Source.MAP)


@extend_schema_field({"type": "object", "description": "the kind's parameters (the catalog)"})
class ParamsField(serializers.JSONField):
    """Any JSON, for the catalog to judge; the schema says what it must be, an object."""


class CommandCreateSerializer(serializers.Serializer):
    """Shape only; the catalog (via command_enqueue) decides what is valid."""

    kind = StrictCharField()
    params = ParamsField(required=False, default=dict)
    expires_at = serializers.DateTimeField(required=False, allow_null=True)
    urgent = StrictBooleanField(
        required=False,
        default=False,
        help_text="also send it at once by the vessel's SMS or Iridium SBD link, if it has one",
    )
    source = serializers.ChoiceField(
        [(s.value, s.label) for s in API_SOURCES],
        required=False,
        default=Source.API,
        help_text="where the command comes from: api (default) or map (the fleet map)",
        error_messages={"invalid_choice": "must be api or map (got {input!r})"},
    )


class CommandCursor(CursorPagination):
    # DRF's default cursor orders by "-created", a field Command does not have (500 on GET).
    ordering = "-created_at"
    page_size = 100
    page_size_query_param = "page_size"
    max_page_size = 1000


class VesselCommandsView(generics.ListCreateAPIView):
    """A vessel's commands, newest first; POST `{"kind": ..., "params": {...}}` queues one."""

    serializer_class = CommandSerializer
    pagination_class = CommandCursor
    queryset = Command.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions, CanViewVessels]

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        vessel = vessel_by_slug(self.kwargs["slug"])
        return Command.objects.filter(vessel=vessel).prefetch_related("events")

    @extend_schema(
        request=CommandCreateSerializer, responses={201: CommandSerializer}, tags=["operator"]
    )
    def post(self, request: Request, *args: Any, **kwargs: Any) -> Response:
        vessel = vessel_by_slug(self.kwargs["slug"])
        incoming = CommandCreateSerializer(data=request.data)
        incoming.is_valid(raise_exception=True)
        command = command_enqueue(
            vessel=vessel,
            kind=incoming.validated_data["kind"],
            params=incoming.validated_data["params"],
            source=incoming.validated_data["source"],
            created_by=request.user.get_username(),
            expires_at=incoming.validated_data.get("expires_at"),
            urgent=incoming.validated_data["urgent"],
        )
        return Response(CommandSerializer(command).data, status=status.HTTP_201_CREATED)


class CommandCancelView(APIView):
    queryset = Command.objects.none()
    permission_classes = [ChangeModelPermissions]  # cancelling changes a command

    @extend_schema(request=None, responses={200: CommandSerializer}, tags=["operator"])
    def post(self, request: Request, uid: str) -> Response:
        """Cancel a queued or sent command."""
        command = command_cancel(command=command_by_uid(uid), actor=request.user.get_username())
        return Response(CommandSerializer(command).data)
