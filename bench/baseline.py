"""Baselines that bench.server measures beside the real boat API, in the same run.

1. ``hello``: a bare Django view returning a small JSON body: the framework floor.
2. ``DrfTelemetryView``: the same ingest as most DRF projects would write it: a
   ``ModelSerializer(many=True)`` validating the fixes, then ``Fix.objects.bulk_create``.
3. ``drf_commands``: the matching straightforward poll: a ``ListAPIView`` of the vessel's open
   commands with ETag/304 from Django's ``ConditionalGetMiddleware`` (hash of the body).

Both DRF baselines authenticate with the project's own vessel key class, so the comparison is
about the ingest and the poll, not about key hashing. Bench-only: never routed by fleet.urls.
"""

from __future__ import annotations

import atexit
import cProfile
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from django.http import HttpRequest, HttpResponse, JsonResponse
from django.middleware.http import ConditionalGetMiddleware
from django.utils import timezone
from rest_framework import generics, serializers
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from commands.models import Command
from telemetry.models import Fix
from vessels.auth import VesselKeyAuthentication
from vessels.permissions import IsBoat


def hello(request: HttpRequest) -> JsonResponse:
    """Baseline 1: the cheapest JSON answer Django gives through the project's middleware."""
    return JsonResponse({"ok": True})


class FixSerializer(serializers.ModelSerializer):
    time = serializers.DateTimeField(source="recorded_at")

    class Meta:
        model = Fix
        fields = ["time", "lat", "lon", "heading_deg", "speed_mps", "battery_v", "readings"]


class DrfTelemetryView(APIView):
    """Baseline 2: serializer-validated fixes, bulk_create, count back."""

    authentication_classes = [VesselKeyAuthentication]
    permission_classes = [IsBoat]

    def post(self, request: Request) -> Response:
        data = request.data
        if isinstance(data, dict):
            data = data.get("fixes")
        serializer = FixSerializer(data=data, many=True)
        serializer.is_valid(raise_exception=True)
        vessel = request.user.vessel
        now = timezone.now()
        created = Fix.objects.bulk_create(
            [Fix(vessel=vessel, received_at=now, **item) for item in serializer.validated_data]
        )
        return Response({"accepted": len(created), "duplicates": 0, "rejected": []})


class CommandSerializer(serializers.ModelSerializer):
    class Meta:
        model = Command
        fields = ["uid", "kind", "params", "created_at", "expires_at"]


class DrfCommandListView(generics.ListAPIView):
    authentication_classes = [VesselKeyAuthentication]
    permission_classes = [IsBoat]
    serializer_class = CommandSerializer
    pagination_class = None

    def get_queryset(self) -> Any:
        return Command.objects.filter(
            vessel=self.request.user.vessel, status__in=["queued", "sent"]
        ).order_by("created_at")

    def list(self, request: Request, *args: Any, **kwargs: Any) -> Response:
        return Response({"commands": self.get_serializer(self.get_queryset(), many=True).data})


_drf_list = DrfCommandListView.as_view()


def drf_commands(request: HttpRequest) -> HttpResponse:
    """Baseline poll: ETag = hash of the rendered body; If-None-Match → 304."""
    return ConditionalGetMiddleware(lambda r: _drf_list(r).render())(request)


class ProfileMiddleware:
    """cProfile every request of this worker; stats go to $BENCH_PROFILE_DIR/worker-<pid>.prof."""

    def __init__(self, get_response: Callable[[HttpRequest], HttpResponse]) -> None:
        self.get_response = get_response
        self.profile = cProfile.Profile()
        self.count = 0
        self.path = Path(os.environ["BENCH_PROFILE_DIR"]) / f"worker-{os.getpid()}.prof"
        atexit.register(self.dump)

    def dump(self) -> None:
        self.profile.dump_stats(self.path)

    def __call__(self, request: HttpRequest) -> HttpResponse:
        response = self.profile.runcall(self.get_response, request)
        self.count += 1
        if self.count % 500 == 0:  # gunicorn may not run atexit on a hard stop
            self.dump()
        return response
