"""Commands out to boats, acks in (docs/api.md): v1 poll and ack, and the report of commands a
vessel created itself (a glider's SMS commands). Thin: services do the work.

The wire shapes are a contract with boats in the field, so these are explicit APIViews that
build their JSON by hand rather than generic serializers.
"""

from __future__ import annotations

from typing import Any

from django.http import HttpResponseNotModified
from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import OpenApiParameter, extend_schema, inline_serializer
from rest_framework import serializers, status
from rest_framework.exceptions import ParseError, ValidationError
from rest_framework.request import Request
from rest_framework.response import Response

from commands.lifecycle import ACK_STATUSES, Status
from commands.models import Command, Source
from commands.services import command_ack, command_claim_open, command_reports_record
from edge_client.contract import exchange
from vessels.api.boat import AwareDateTimeField, BoatView, batch_answer_schema
from vessels.api.conditional import etag_matches
from vessels.api.fields import StrictCharField
from vessels.batch import Unreadable
from vessels.models import Vessel
from vessels.selectors import vessel_commands_version
from vessels.text import json_unstorable, unstorable


def commands_etag(vessel: Vessel, version: int | None = None) -> str:
    """Changes whenever the vessel's open command list does (Vessel.commands_version, or
    ``version`` when the caller read it afresh)."""
    return f'"c{vessel.pk}.{vessel.commands_version if version is None else version}"'


def commands_since(vessel: Vessel, held: str | None, etag: str) -> list[dict[str, Any]] | None:
    """The poll's ``commands`` for a boat holding ETag ``held`` (an If-None-Match value), or
    None when ``held`` still matches ``etag``, the list's ETag now.

    The one delivery path of the v1 boat API, for the poll and for the telemetry answer alike
    (edge_client.contract.exchange): the list is claimed as the poll claims it (queued ones
    marked sent, expired ones expired: command_claim_open). ``etag`` is read before the list:
    if a command arrives meanwhile, the tag is older than the list and the boat just fetches
    once more; the other order could hide a command."""
    if etag_matches(held, etag):
        return None
    return [command_wire(c) for c in command_claim_open(vessel=vessel)]


def commands_exchange(vessel: Vessel, held: str) -> dict[str, Any]:
    """What a telemetry answer adds for a boat holding ETag ``held`` (the X-Commands-ETag
    header): ``commands_etag``, and ``commands`` when the list changed since ``held``.

    ``vessel`` may come from the recent key lookups, its commands_version a minute old: the
    version is read afresh (one indexed SELECT). A value too long to be one of our tags is
    taken as none held (the whole list follows), never parsed."""
    etag = commands_etag(vessel, vessel_commands_version(vessel.pk))
    if len(held) > exchange.MAX_HELD:
        held = exchange.NONE_HELD
    commands = commands_since(vessel, held, etag)
    if commands is None:
        return {exchange.ETAG_KEY: etag}
    return {exchange.COMMANDS_KEY: commands, exchange.ETAG_KEY: etag}


def command_wire(command: Command) -> dict[str, Any]:
    return {
        "uid": str(command.uid),
        "kind": command.kind,
        "params": command.params,
        "created_at": command.created_at.isoformat(),
        "expires_at": command.expires_at.isoformat() if command.expires_at else None,
    }


_CommandsOut = inline_serializer(
    "BoatCommand",
    many=True,
    fields={
        "uid": serializers.UUIDField(),
        "kind": serializers.CharField(),
        "params": serializers.DictField(),
        "created_at": serializers.DateTimeField(),
        "expires_at": serializers.DateTimeField(allow_null=True),
    },
)
_CommandList = inline_serializer("BoatCommandList", {"commands": _CommandsOut})


class CommandListView(BoatView):
    @extend_schema(
        parameters=[OpenApiParameter("If-None-Match", str, OpenApiParameter.HEADER)],
        responses={200: _CommandList, 304: None},
        tags=["boat"],
    )
    def get(self, request: Request) -> Response | HttpResponseNotModified:
        """Open commands for this vessel, oldest first; `304` when the ETag still matches."""
        vessel = self.vessel(request)
        etag = commands_etag(vessel)
        commands = commands_since(vessel, request.META.get("HTTP_IF_NONE_MATCH"), etag)
        response = (
            HttpResponseNotModified() if commands is None else Response({"commands": commands})
        )
        response["ETag"] = etag
        return response

    @extend_schema(exclude=True)
    def head(self, request: Request) -> Response | HttpResponseNotModified:
        """The ETag alone. Django would route HEAD to get(), and a read must never hand a
        command over: the boat would never see the body, yet the command would be `sent`."""
        etag = commands_etag(self.vessel(request))
        matches = etag_matches(request.META.get("HTTP_IF_NONE_MATCH"), etag)
        response = HttpResponseNotModified() if matches else Response()
        response["ETag"] = etag
        return response


class AckView(BoatView):
    @extend_schema(
        request=inline_serializer(
            "Ack",
            {
                "status": serializers.ChoiceField([str(s) for s in ACK_STATUSES]),
                # A NUL is refused (the one text rule), so the schema says so: StrictCharField.
                "detail": StrictCharField(required=False, allow_blank=True),
            },
        ),
        responses={200: OpenApiTypes.OBJECT},
        tags=["boat"],
    )
    def post(self, request: Request, uid: str) -> Response:
        """Report `acknowledged`, `done`, `failed` or `superseded` (replaced on the boat by a
        newer command) for a command. Idempotent."""
        data = request.data
        if not isinstance(data, dict):
            raise ParseError('Expected a JSON object {"status": ..., "detail": ...}.')
        detail = data.get("detail", "")
        if not isinstance(detail, str):
            raise ValidationError({"detail": ["must be a string"]})
        if problem := unstorable(detail):  # the boat API's one rule: refused, never rewritten
            raise ValidationError({"detail": [problem]})
        command, _changed = command_ack(
            vessel=self.vessel(request), uid=uid, status=data.get("status"), detail=detail
        )
        return Response({"uid": str(command.uid), "status": command.status}, status.HTTP_200_OK)


# Commands per report: the glider sends its backlog in batches of this size or fewer.
COMMAND_REPORT_MAX_BATCH = 200
RESULT_DETAIL_MAX = 2000


class ReportedCommandIn(serializers.Serializer):
    """One command the vessel created itself, as it stands on the vessel now."""

    uid = serializers.UUIDField()
    kind = serializers.CharField(max_length=20)
    params = serializers.DictField(required=False, default=dict)
    source = serializers.ChoiceField(
        [*Source.choices, ("system", "System (the older name of vessel)")],
        required=False,
        default=Source.SMS,
        help_text="sms or vessel (system, the older name, is taken as vessel)",
    )
    created_by = serializers.CharField(max_length=150, required=False, allow_blank=True)
    created_at = AwareDateTimeField(help_text="when the vessel created it")
    # A plain string, checked by the service: a ChoiceField would give the OpenAPI schema a
    # second "status" enum colliding with the operator API's.
    status = serializers.CharField(
        max_length=20, help_text="its status there: " + ", ".join(s.value for s in Status)
    )
    sent_at = AwareDateTimeField(required=False, allow_null=True)
    acknowledged_at = AwareDateTimeField(required=False, allow_null=True)
    finished_at = AwareDateTimeField(required=False, allow_null=True)
    result_detail = serializers.CharField(
        max_length=RESULT_DETAIL_MAX, required=False, allow_blank=True, trim_whitespace=False
    )

    def validate_params(self, value: dict[str, Any]) -> dict[str, Any]:
        # Before the catalog, whose error would echo a bad name into a reply it cannot encode.
        if problem := json_unstorable(value):
            raise serializers.ValidationError(problem)
        return value


def reports_from_body(data: Any) -> list[Any]:
    """The entries of {"commands": [...]}; anything else is a 400 naming the problem."""
    commands = data.get("commands") if isinstance(data, dict) else None
    if not isinstance(commands, list):
        raise ParseError('Expected a JSON object {"commands": [...]}.')
    if len(commands) > COMMAND_REPORT_MAX_BATCH:
        raise ParseError(f"At most {COMMAND_REPORT_MAX_BATCH} commands per report.")
    return commands


class CommandReportView(BoatView):
    @extend_schema(
        request=inline_serializer("CommandReport", {"commands": ReportedCommandIn(many=True)}),
        responses={200: batch_answer_schema("CommandReportResult")},
        tags=["boat"],
    )
    def post(self, request: Request) -> Response:
        """Mirror the commands the vessel created itself (a glider's SMS commands), each as
        it stands there now. New or moved forward: accepted; repeated, older, or one of the
        shore's own commands: a duplicate; bad entries are reported by index, the good kept."""
        reports = [_report_read(raw) for raw in reports_from_body(request.data)]
        answer = command_reports_record(vessel=self.vessel(request), reports=reports)
        return Response(answer.as_dict())


def _report_read(raw: Any) -> dict[str, Any] | Unreadable:
    """One report's wire shape, read; what the command means is the service's to check."""
    entry = ReportedCommandIn(data=raw) if isinstance(raw, dict) else None
    if entry is None or not entry.is_valid():
        return Unreadable(entry.errors if entry is not None else {"entry": ["not an object"]})
    return dict(entry.validated_data)
