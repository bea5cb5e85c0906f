from __future__ import annotations

from django.contrib import admin
from django.urls import include, path
from drf_spectacular.views import SpectacularAPIView, SpectacularSwaggerView
from rest_framework.permissions import IsAuthenticated
from rest_framework.routers import DefaultRouter

from commands.api import boat, operator
from commands.legacy import LegacyCommandsView, LegacyDataView
from telemetry.api.views import VesselFixesView
from vessels.api.views import VesselViewSet

admin.site.site_header = "Shoreside"
admin.site.site_title = "Shoreside"
admin.site.index_title = "Fleet"

router = DefaultRouter(trailing_slash=True)
router.include_root_view = False
router.register("vessels", VesselViewSet, basename="vessel")

api_v1 = [
    path("boat/telemetry/", boat.TelemetryView.as_view(), name="boat-telemetry"),
    path("boat/commands/", boat.CommandListView.as_view(), name="boat-commands"),
    path("boat/commands/<str:uid>/ack/", boat.AckView.as_view(), name="boat-ack"),
    path("vessels/<slug:slug>/fixes/", VesselFixesView.as_view(), name="vessel-fixes"),
    path(
        "vessels/<slug:slug>/commands/",
        operator.VesselCommandsView.as_view(),
        name="vessel-commands",
    ),
    path("commands/<str:uid>/cancel/", operator.CommandCancelView.as_view(), name="command-cancel"),
    path(
        "schema/", SpectacularAPIView.as_view(permission_classes=[IsAuthenticated]), name="schema"
    ),
    path(
        "docs/",
        SpectacularSwaggerView.as_view(url_name="schema", permission_classes=[IsAuthenticated]),
        name="api-docs",
    ),
    path("", include(router.urls)),
]

urlpatterns = [
    path("admin/", admin.site.urls),
    path("api/v1/", include(api_v1)),
    path("spab/data.cgi", LegacyDataView.as_view(), name="legacy-data"),
    path("spab/requestCommands.cgi", LegacyCommandsView.as_view(), name="legacy-commands"),
    path("", include("fleet.pages")),
]
