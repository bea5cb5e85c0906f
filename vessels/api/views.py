from __future__ import annotations

from rest_framework import viewsets

from vessels.api.serializers import VesselSerializer
from vessels.selectors import vessel_list


class VesselViewSet(viewsets.ReadOnlyModelViewSet):
    """Vessels with their last fix and state (reporting, overdue, never seen)."""

    serializer_class = VesselSerializer
    lookup_field = "slug"
    pagination_class = None

    def get_queryset(self):  # noqa: ANN201 (DRF hook)
        return vessel_list()
