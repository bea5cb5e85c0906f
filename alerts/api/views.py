"""Operator API for alerts: `/api/v1/alert-rules/` (CRUD), `/api/v1/alerts/` (read, filter by
state and vessel; `POST …/<id>/ack/`) and `/api/v1/notification-channels/` (read, create: a
webhook's secret is in the creation's answer and never again). Writes go through
alerts.services; model permissions as everywhere in the operator API."""

from __future__ import annotations

import re
from typing import Any

from django.utils import timezone
from drf_spectacular.utils import OpenApiParameter, extend_schema, extend_schema_view
from rest_framework import exceptions, mixins, status, viewsets
from rest_framework.decorators import action
from rest_framework.pagination import CursorPagination
from rest_framework.request import Request
from rest_framework.response import Response

from alerts.api.serializers import (
    AlertRuleSerializer,
    AlertSerializer,
    ChannelCreatedSerializer,
    ChannelCreateSerializer,
    ChannelSerializer,
    who,
)
from alerts.models import Alert, AlertRule, AlertState, NotificationChannel
from alerts.services.alerts import alert_acknowledge
from alerts.services.notifications import notification_channel_create
from alerts.services.rules import alert_rule_delete
from vessels.api.parsers import JSONParser
from vessels.permissions import CanViewVessels, ChangeModelPermissions, ModelPermissions


class AlertConflict(exceptions.APIException):
    """The alert's state refuses this (a resolved alert cannot be acknowledged)."""

    status_code = status.HTTP_409_CONFLICT
    default_code = "conflict"


@extend_schema(tags=["operator"])
class AlertRuleViewSet(viewsets.ModelViewSet):
    """Alert rules, per vessel or for every vessel (of a kind): overdue (`threshold` telemetry
    periods), battery (`threshold` volts), reading (`reading` outside `min`/`max`),
    endurance (`threshold` hours), fence (`fence`), command (failed or expired)."""

    serializer_class = AlertRuleSerializer
    queryset = AlertRule.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions]
    pagination_class = None
    parser_classes = [JSONParser]
    http_method_names = ["get", "post", "patch", "delete", "head", "options"]

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        rules = AlertRule.objects.select_related("vessel", "fence").prefetch_related("channels")
        # A rule names its vessel: without the right to see vessels, only the fleet-wide ones.
        if not self.request.user.has_perm("vessels.view_vessel"):
            rules = rules.filter(vessel__isnull=True)
        return rules.order_by("name", "pk")

    def perform_destroy(self, instance: AlertRule) -> None:
        alert_rule_delete(rule=instance, **who(self.request))


class AlertCursor(CursorPagination):
    ordering = ("-opened_at", "-id")
    page_size = 100
    page_size_query_param = "page_size"
    max_page_size = 1000

    def get_page_size(self, request: Request) -> int:
        # DRF ignores a page_size that is no number; the schema says integer, so it is a 400.
        # A whole number under 1 is one, and gets the default size, as DRF gives it.
        given = request.query_params.getlist(self.page_size_query_param)
        if not all(re.fullmatch(r"[+-]?[0-9]+", value) for value in given):
            raise exceptions.ValidationError({"page_size": ["a whole number"]})
        return super().get_page_size(request)

    def decode_cursor(self, request: Request) -> Any:
        # DRF answers a bad cursor 404; on a list's own path that is bad input (400).
        try:
            return super().decode_cursor(request)
        except exceptions.NotFound:
            raise exceptions.ValidationError({"cursor": ["not a cursor this list gave"]}) from None


@extend_schema(tags=["operator"])
@extend_schema_view(
    list=extend_schema(
        parameters=[
            OpenApiParameter("state", str, enum=[s.value for s in AlertState]),
            OpenApiParameter("vessel", str, description="a vessel's slug"),
        ]
    )
)
class AlertViewSet(mixins.ListModelMixin, mixins.RetrieveModelMixin, viewsets.GenericViewSet):
    """Alerts, newest first: one per episode of a rule's condition on a vessel. `open` until
    acknowledged (`POST …/ack/`) or resolved (the condition cleared)."""

    serializer_class = AlertSerializer
    queryset = Alert.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions, CanViewVessels]  # an alert names its vessel
    pagination_class = AlertCursor

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        alerts = Alert.objects.select_related("vessel", "rule")
        if self.action != "list":
            return alerts
        state = self.request.query_params.get("state")
        if state is not None:
            if state not in AlertState.values:
                raise exceptions.ValidationError(
                    {"state": [f"one of {', '.join(AlertState.values)}"]}
                )
            alerts = alerts.filter(state=state)
        vessel = self.request.query_params.get("vessel")
        if vessel is not None:
            alerts = alerts.filter(vessel__slug=vessel)
        return alerts

    @extend_schema(request=None, responses={200: AlertSerializer})
    @action(
        detail=True, methods=["post"], permission_classes=[ChangeModelPermissions, CanViewVessels]
    )
    def ack(self, request: Request, pk: str | None = None) -> Response:
        """Acknowledge an open alert: who and when are recorded, its channels told. An
        acknowledged one stays as it was (200); a resolved one cannot be (409)."""
        alert = self.get_object()
        if alert.state == AlertState.RESOLVED:
            raise AlertConflict("the alert is resolved; there is nothing to acknowledge")
        # Already acknowledged (by someone else, a moment ago) is answered as it stands.
        alert_acknowledge(alert=alert, by=request.user.get_username(), now=timezone.now())
        alert.refresh_from_db()
        return Response(AlertSerializer(alert).data)


@extend_schema(tags=["operator"])
class ChannelViewSet(
    mixins.ListModelMixin,
    mixins.RetrieveModelMixin,
    mixins.CreateModelMixin,
    viewsets.GenericViewSet,
):
    """Where alerts are told: e-mail, SMS or a signed webhook. A webhook's secret (given, or
    generated) is returned once, in the answer to its creation."""

    serializer_class = ChannelSerializer
    queryset = NotificationChannel.objects.none()  # for the model permission check
    permission_classes = [ModelPermissions]
    pagination_class = None
    parser_classes = [JSONParser]

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        return NotificationChannel.objects.order_by("name", "pk")

    @extend_schema(request=ChannelCreateSerializer, responses={201: ChannelCreatedSerializer})
    def create(self, request: Request, *args: Any, **kwargs: Any) -> Response:
        incoming = ChannelCreateSerializer(data=request.data)
        incoming.is_valid(raise_exception=True)
        channel, secret = notification_channel_create(
            **incoming.validated_data, by=request.user.get_username()
        )
        body = {**ChannelSerializer(channel).data, "secret": secret or ""}
        return Response(body, status=status.HTTP_201_CREATED)
