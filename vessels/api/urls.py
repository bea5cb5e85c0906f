"""Operator API for vessels, under /api/v1/."""

from __future__ import annotations

from rest_framework.routers import DefaultRouter

from vessels.api.views import VesselViewSet

router = DefaultRouter(trailing_slash=True)
router.include_root_view = False
router.register("vessels", VesselViewSet, basename="vessel")

urlpatterns = router.urls
