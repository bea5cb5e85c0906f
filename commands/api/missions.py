"""`POST /api/v1/missions/<id>/send/`: queue a mission as a `mission` command.

Here, not beside the mission API in vessels: it writes a command, and vessels sits below
commands (docs/architecture.md). The checks are the ones every mission command passes
(commands.services.command_validate: the catalog, then the route with MISSION_MAX_LEG_M).
"""

from __future__ import annotations

from django.shortcuts import get_object_or_404
from drf_spectacular.utils import extend_schema
from rest_framework import serializers, status
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from commands.api.operator import CommandSerializer
from commands.models import Command, Source
from commands.services import mission_send
from vessels.models import Vessel
from vessels.permissions import CanViewVessels, ModelPermissions
from vessels.selectors import missions_visible_to


class SendToVesselSerializer(serializers.Serializer):
    """The body of a "send this to a vessel" request (a mission, a fence): ``vessel``, a slug."""

    def validate_vessel(self, slug: str) -> Vessel:
        # A field of the body, not the URL: an unknown slug is bad input (400), not a 404.
        vessel = Vessel.objects.filter(slug=slug).first()
        if vessel is None:
            raise serializers.ValidationError(f"no vessel {slug!r}")
        return vessel


class MissionSendSerializer(SendToVesselSerializer):
    vessel = serializers.SlugField(
        required=False, help_text="slug of the vessel to run it (default: the mission's own)"
    )

    updated_at = serializers.DateTimeField(
        required=False,
        help_text="the mission's `updated_at` as the caller last read it: if the mission was "
        "saved since, nothing is sent (400), so what goes out is what the caller saw",
    )


class MissionSendView(APIView):
    queryset = Command.objects.none()  # sending needs commands.add_command
    permission_classes = [ModelPermissions, CanViewVessels]

    @extend_schema(
        request=MissionSendSerializer, responses={201: CommandSerializer}, tags=["operator"]
    )
    def post(self, request: Request, pk: int) -> Response:
        """Queue the mission for its vessel (or `vessel`), checked first: 400 says why not."""
        mission = get_object_or_404(missions_visible_to(request.user), pk=pk)
        incoming = MissionSendSerializer(data=request.data)
        incoming.is_valid(raise_exception=True)
        command = mission_send(
            mission=mission,
            vessel=incoming.validated_data.get("vessel"),
            source=Source.API,
            created_by=request.user.get_username(),
            seen_at=incoming.validated_data.get("updated_at"),
        )
        return Response(CommandSerializer(command).data, status=status.HTTP_201_CREATED)
