"""Operator API for vessels and missions, under /api/v1/."""

from __future__ import annotations

from django.urls import path
from rest_framework.routers import DefaultRouter

from vessels.api.missions import MissionViewSet
from vessels.api.views import FleetView, VesselViewSet

router = DefaultRouter(trailing_slash=True)
router.include_root_view = False
router.register("vessels", VesselViewSet, basename="vessel")
router.register("missions", MissionViewSet, basename="mission")

urlpatterns = [path("fleet/", FleetView.as_view(), name="fleet"), *router.urls]
