"""The thesis' SPAB endpoints, on the same services (DESIGN §5 "Legacy SPAB wire format").

`POST /spab/data.cgi` takes Listing 1 records and answers the old `telemAck`;
`GET /spab/requestCommands.cgi` answers Listing 2, with the command uid as a stable `taskId`.
"""

from __future__ import annotations

from typing import Any

from django.conf import settings
from drf_spectacular.utils import extend_schema
from rest_framework import status
from rest_framework.exceptions import APIException
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from commands.models import Command
from commands.services import command_deliver_legacy
from telemetry.services import fix_ingest
from vessels.auth import LegacyKeyAuthentication
from vessels.permissions import IsBoat

_LEGACY_ACTION = {"move_to": "moveTo", "hold": "hold"}


def telem_ack(success: bool, message: str) -> list[dict[str, str]]:
    return [{"type": "telemAck"}, {"success": "true" if success else "false", "message": message}]


def legacy_command(command: Command) -> dict[str, Any]:
    item: dict[str, Any] = {
        "action": _LEGACY_ACTION[command.kind],
        "timestamp": int(command.created_at.timestamp()),
        "taskId": str(command.uid),
    }
    if command.kind == "move_to":
        item["latitude"] = command.params["lat"]
        item["longitude"] = command.params["lon"]
    return item


class LegacyView(APIView):
    authentication_classes = [LegacyKeyAuthentication]
    permission_classes = [IsBoat]

    def handle_exception(self, exc: Exception) -> Response:
        # The old client understood only telemAck arrays; keep the status code as well.
        response = super().handle_exception(exc)
        if isinstance(exc, APIException):
            response.data = telem_ack(False, str(exc.detail))
        return response


@extend_schema(exclude=True)
class LegacyDataView(LegacyView):
    def post(self, request: Request) -> Response:
        data = request.data
        records = [data] if isinstance(data, dict) else data
        if not isinstance(records, list):
            return Response(
                telem_ack(False, "expected a JSON object or a list of objects"),
                status=status.HTTP_400_BAD_REQUEST,
            )
        if len(records) > settings.FIX_MAX_BATCH:
            # Say which limit, or the old client's operator chases a shape problem.
            return Response(
                telem_ack(
                    False,
                    f"at most {settings.FIX_MAX_BATCH} records per request (got {len(records)})",
                ),
                status=status.HTTP_400_BAD_REQUEST,
            )
        result = fix_ingest(vessel=request.user.vessel, records=records, legacy=True)
        message = (
            f"accepted {result.accepted}, duplicates {result.duplicates}, "
            f"rejected {len(result.rejected)}"
        )
        for rejected in result.rejected:
            fields = ", ".join(f"{k} {v}" for k, v in rejected["errors"].items())
            message += f"; record {rejected['index']}: {fields}"
        ok = not result.rejected
        return Response(
            telem_ack(ok, message),
            status=200 if ok or result.accepted or result.duplicates else 400,
        )


@extend_schema(exclude=True)
class LegacyCommandsView(LegacyView):
    def get(self, request: Request) -> Response:
        commands = command_deliver_legacy(vessel=request.user.vessel)
        return Response([{"type": "command"}] + [legacy_command(c) for c in commands])
