"""GET /api/v1/audit/: the audit log, newest first, filtered by the query.

Permissions are the API's default (settings.REST_FRAMEWORK: Django model permissions, reads
needing ``audit.view_auditentry``); this app is the floor of the layers and names no class
from above it.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.db.models import Q, QuerySet
from django.utils import timezone
from django.utils.dateparse import parse_datetime
from drf_spectacular.utils import OpenApiParameter, extend_schema
from rest_framework.exceptions import NotFound, ValidationError
from rest_framework.generics import ListAPIView
from rest_framework.pagination import Cursor, CursorPagination
from rest_framework.request import Request

from audit.api.serializers import AuditEntrySerializer
from audit.models import ActorKind, AuditEntry

# A query value no database column can hold is refused by the site before the view
# (fleet.middleware.RejectNulMiddleware); the schema says so.
TEXT = {"type": "string", "pattern": "^[^\\u0000]*$"}
WHEN = {"type": "string", "format": "date-time"}


class AuditCursor(CursorPagination):
    # No OFFSET and no COUNT, however long the log grows.
    ordering = "-at"
    page_size = 100
    page_size_query_param = "page_size"
    max_page_size = 1000

    def get_page_size(self, request: Request) -> int:
        # DRF ignores a page size it cannot read; here it is bad input, as the schema says.
        raw = request.query_params.get(self.page_size_query_param)
        if raw is None:
            return self.page_size
        try:
            size = int(raw)
        except ValueError:
            size = 0
        if not 1 <= size <= self.max_page_size:
            raise ValidationError(
                {"page_size": [f"{raw!r} is not a whole number from 1 to {self.max_page_size}"]}
            )
        return size

    def get_schema_operation_parameters(self, view: Any) -> list[dict[str, Any]]:
        parameters = super().get_schema_operation_parameters(view)
        for parameter in parameters:
            if parameter["name"] == self.page_size_query_param:
                parameter["schema"] |= {"minimum": 1, "maximum": self.max_page_size}
        return parameters

    def decode_cursor(self, request: Request) -> Cursor | None:
        # DRF answers a cursor it cannot read with 404; this list's URL names nothing that
        # could be missing, so it is bad input (400), as the schema says.
        try:
            return super().decode_cursor(request)
        except NotFound:
            raise ValidationError({"cursor": ["not a cursor this list gave"]}) from None


def when_param(request: Request, name: str) -> dt.datetime | None:
    """An ISO 8601 date-time query parameter; without an offset, it is UTC. Given empty, it
    is no date-time (400), as the schema says."""
    raw = request.query_params.get(name)
    if raw is None:
        return None
    try:
        value = parse_datetime(raw)
    except ValueError:  # well formed, but no such time (a 13th month)
        value = None
    if value is None:
        raise ValidationError({name: [f"{raw!r} is not an ISO 8601 date-time"]})
    if not timezone.is_aware(value):
        return value.replace(tzinfo=dt.UTC)
    # In UTC before it reaches the database: PostgreSQL refuses offsets past ±15:59, which
    # ISO 8601 (and Python) allow.
    try:
        return value.astimezone(dt.UTC)
    except OverflowError:  # the first hours of year 1, or the last of 9999, moved off the edge
        raise ValidationError({name: [f"{raw!r} is out of range"]}) from None


def entries_matching(request: Request) -> QuerySet[AuditEntry]:
    """The entries the query asks for (every filter optional; all given must hold)."""
    query = request.query_params
    entries = AuditEntry.objects.all()
    for name in ("vessel", "actor", "via", "subject_type", "subject_id"):
        if value := query.get(name):
            entries = entries.filter(**{name: value})
    if (kind := query.get("actor_kind")) is not None:
        if kind not in ActorKind.values:
            choices = ", ".join(ActorKind.values)
            raise ValidationError({"actor_kind": [f"{kind!r} is not one of {choices}"]})
        entries = entries.filter(actor_kind=kind)
    if action := query.get("action"):
        # "command.queued" is one action; "command" is all of them (command.queued, …).
        family = Q() if "." in action else Q(action__startswith=f"{action}.")
        entries = entries.filter(Q(action=action) | family)
    if since := when_param(request, "since"):
        entries = entries.filter(at__gte=since)
    if until := when_param(request, "until"):
        entries = entries.filter(at__lt=until)
    return entries


@extend_schema(
    parameters=[
        OpenApiParameter("vessel", TEXT, description="a vessel's slug (deleted ones too)"),
        OpenApiParameter(
            "action",
            TEXT,
            description="one action (`command.queued`), or every action of a kind (`command`)",
        ),
        OpenApiParameter("actor", TEXT, description="a user name, phone number or vessel slug"),
        OpenApiParameter("actor_kind", str, enum=ActorKind.values),
        OpenApiParameter("via", TEXT, description="the way in: admin, api, map, sms, cli, …"),
        OpenApiParameter("subject_type", TEXT, description="e.g. command, vessel key"),
        OpenApiParameter("subject_id", TEXT, description="with subject_type: one object's"),
        OpenApiParameter("since", WHEN, description="ISO 8601 (inclusive); UTC without offset"),
        OpenApiParameter("until", WHEN, description="ISO 8601 (exclusive); UTC without offset"),
    ],
    tags=["operator"],
)
class AuditEntryList(ListAPIView):
    """Who did what, from where: the audit log, newest first, cursor-paginated."""

    serializer_class = AuditEntrySerializer
    pagination_class = AuditCursor
    queryset = AuditEntry.objects.none()  # for the model permission check

    def get_queryset(self) -> QuerySet[AuditEntry]:
        return entries_matching(self.request)
