from __future__ import annotations

import datetime as dt
import hashlib
import json
from typing import Any

from django.http import HttpResponse
from django.urls import reverse
from drf_spectacular.utils import OpenApiParameter, OpenApiResponse, extend_schema
from rest_framework import viewsets
from rest_framework.request import Request
from rest_framework.response import Response
from rest_framework.views import APIView

from edge_client.contract import fix as fix_shape
from vessels.api.conditional import etag_matches
from vessels.api.serializers import FleetSerializer, VesselSerializer, VesselUpdateSerializer
from vessels.models import Vessel
from vessels.permissions import ModelPermissions
from vessels.selectors import fleet_vessels, vessel_list
from vessels.services import vessel_update


class VesselViewSet(viewsets.ReadOnlyModelViewSet):
    """Vessels with their last fix and state (reporting, overdue, never seen); PATCH changes
    an operator's settings of one (`move_to_max_m`, `imei`; needs vessels.change_vessel)."""

    serializer_class = VesselSerializer
    lookup_field = "slug"
    pagination_class = None
    http_method_names = ["get", "patch", "head", "options"]

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        return vessel_list()

    @extend_schema(request=VesselUpdateSerializer, responses={200: VesselSerializer})
    def partial_update(self, request: Request, slug: str) -> Response:
        vessel = self.get_object()
        incoming = VesselUpdateSerializer(vessel, data=request.data, partial=True)
        incoming.is_valid(raise_exception=True)
        vessel = vessel_update(vessel=vessel, fields=incoming.validated_data)
        return Response(VesselSerializer(vessel).data)


LAST_FIX_FIELDS = fix_shape.FIELDS  # the copy kept on Vessel.last_fix is a fix as posted


def admin_url_template() -> str:
    """The vessel admin's change URL with `{pk}` in it: one reverse() per poll, not per vessel."""
    return reverse("admin:vessels_vessel_change", args=[987654321]).replace("987654321", "{pk}")


def fleet_entry(vessel: Vessel, now: dt.datetime, admin_url: str) -> dict[str, Any]:
    last = vessel.last_fix
    return {
        "slug": vessel.slug,
        "name": vessel.name,
        "kind": vessel.kind,
        "status": vessel.status(now),
        "telemetry_period_s": vessel.telemetry_period_s,
        "last_seen_at": vessel.last_seen_at.isoformat() if vessel.last_seen_at else None,
        "last_fix": {k: last.get(k) for k in LAST_FIX_FIELDS} if last else None,
        "admin_url": admin_url.format(pk=vessel.pk),
    }


@extend_schema(
    parameters=[OpenApiParameter("If-None-Match", str, OpenApiParameter.HEADER)],
    responses={200: FleetSerializer, 304: OpenApiResponse(description="Not modified")},
    tags=["operator"],
)
class FleetView(APIView):
    """Every active vessel for the fleet map, with an ETag: poll with `If-None-Match`.

    The ETag covers everything but `server_time`, the statuses included: a vessel turning
    overdue changes it even though no row changed.
    """

    queryset = Vessel.objects.none()  # for the model permission check (view_vessel)
    permission_classes = [ModelPermissions]

    def get(self, request: Request) -> HttpResponse:
        now = dt.datetime.now(dt.UTC)
        admin_url = admin_url_template()
        vessels = [fleet_entry(v, now, admin_url) for v in fleet_vessels()]
        encoded = json.dumps(vessels, separators=(",", ":"), sort_keys=True)
        etag = '"' + hashlib.sha256(encoded.encode()).hexdigest()[:32] + '"'
        if etag_matches(request.headers.get("If-None-Match"), etag):
            response = HttpResponse(status=304)
        else:
            body = '{"server_time":"%s","vessels":%s}' % (now.isoformat(), encoded)  # noqa: UP031
            response = HttpResponse(body, content_type="application/json")
        response["ETag"] = etag
        response["Cache-Control"] = "private, no-cache"
        return response
