"""The original SPAB client's `GET /spab/requestCommands.cgi` (docs/api.md#legacy-spab-endpoints),
with the command uid as a stable `taskId`, on the same services as the v1 poll."""

from __future__ import annotations

from typing import Any

from drf_spectacular.utils import extend_schema
from rest_framework.request import Request
from rest_framework.response import Response

from commands.models import Command
from commands.services import command_deliver_legacy
from vessels.api.boat import LegacyBoatView

_LEGACY_ACTION = {"move_to": "moveTo", "hold": "hold"}


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


@extend_schema(exclude=True)
class LegacyCommandsView(LegacyBoatView):
    def get(self, request: Request) -> Response:
        commands = command_deliver_legacy(vessel=self.vessel(request))
        return Response([{"type": "command"}] + [legacy_command(c) for c in commands])

    def head(self, request: Request) -> Response:
        # Not get(): delivery to a legacy client counts as acknowledged, and HEAD reads.
        return Response()
