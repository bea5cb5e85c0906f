"""Telemetry endpoints: the fix reads under /api/v1/ (the boat's v1 telemetry is routed by
fleet.urls); data.cgi under /spab/ (``legacy_urlpatterns``)."""

from __future__ import annotations

from django.urls import path

from telemetry.api.boat import LegacyDataView
from telemetry.api.maps import (
    VesselNearestFixView,
    VesselSeriesView,
    VesselTrackExportView,
    VesselTrackView,
)
from telemetry.api.views import VesselFixesView

# boat/telemetry/ (TelemetryView) is routed by fleet.urls, which gives it the command list's
# exchange from the commands app.
urlpatterns = [
    path("vessels/<slug:slug>/fixes/", VesselFixesView.as_view(), name="vessel-fixes"),
    path(
        "vessels/<slug:slug>/fixes/nearest/",
        VesselNearestFixView.as_view(),
        name="vessel-fix-nearest",
    ),
    path("vessels/<slug:slug>/track/", VesselTrackView.as_view(), name="vessel-track"),
    path(
        "vessels/<slug:slug>/track/export/",
        VesselTrackExportView.as_view(),
        name="vessel-track-export",
    ),
    path("vessels/<slug:slug>/series/", VesselSeriesView.as_view(), name="vessel-series"),
]

legacy_urlpatterns = [path("data.cgi", LegacyDataView.as_view(), name="legacy-data")]
