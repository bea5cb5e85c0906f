"""Commands out to boats, acks in (DESIGN §5): v1 poll and ack. Thin: services do the work.

The wire shapes are a contract with boats in the field, so these are explicit APIViews that
build their JSON by hand rather than generic serializers.
"""

from __future__ import annotations

from typing import Any

from django.http import HttpResponseNotModified
from django.utils.http import parse_etags
from drf_spectacular.types import OpenApiTypes
from drf_spectacular.utils import OpenApiParameter, extend_schema, inline_serializer
from rest_framework import serializers, status
from rest_framework.exceptions import ParseError, ValidationError
from rest_framework.request import Request
from rest_framework.response import Response

from commands.models import Command
from commands.services import command_ack, command_claim_open
from vessels.api.boat import BoatView
from vessels.models import Vessel


def commands_etag(vessel: Vessel) -> str:
    """Changes whenever the vessel's open command list does (Vessel.commands_version)."""
    return f'"c{vessel.pk}.{vessel.commands_version}"'


def etag_matches(if_none_match: str | None, etag: str) -> bool:
    """RFC 9110 §13.1.2: If-None-Match may list several tags and compares weakly, so a
    proxy that weakened our tag (nginx does when it gzips) still earns the boat its 304."""
    if not if_none_match:
        return False
    if if_none_match == etag:  # the common case, without parsing
        return True
    return any(tag.removeprefix("W/") == etag for tag in parse_etags(if_none_match))


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
        # Read before listing: if a command arrives meanwhile, the tag is older than the list
        # and the boat just fetches once more; the other order could hide a command.
        etag = commands_etag(vessel)
        if etag_matches(request.META.get("HTTP_IF_NONE_MATCH"), etag):
            response = HttpResponseNotModified()
            response["ETag"] = etag
            return response
        commands = command_claim_open(vessel=vessel)
        response = Response({"commands": [command_wire(c) for c in commands]})
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
                "status": serializers.ChoiceField(["acknowledged", "done", "failed"]),
                "detail": serializers.CharField(required=False),
            },
        ),
        responses={200: OpenApiTypes.OBJECT},
        tags=["boat"],
    )
    def post(self, request: Request, uid: str) -> Response:
        """Report `acknowledged`, `done` or `failed` for a command. Idempotent."""
        data = request.data
        if not isinstance(data, dict):
            raise ParseError('Expected a JSON object {"status": ..., "detail": ...}.')
        detail = data.get("detail", "")
        if not isinstance(detail, str):
            raise ValidationError({"detail": ["must be a string"]})
        command, _changed = command_ack(
            vessel=self.vessel(request), uid=uid, status=data.get("status"), detail=detail
        )
        return Response({"uid": str(command.uid), "status": command.status}, status.HTTP_200_OK)
