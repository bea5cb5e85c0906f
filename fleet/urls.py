from __future__ import annotations

from django.contrib import admin
from django.urls import include, path
from drf_spectacular.views import SpectacularSwaggerView
from rest_framework.permissions import IsAuthenticated

from alerts.api import urls as alert_urls
from commands.api import urls as command_urls
from commands.api.boat import commands_exchange
from fleet.console_api import FleetAlertsView, FleetOverlaysView
from fleet.schema import SchemaView
from sbd.api import urls as sbd_urls
from sms.api import urls as sms_urls
from telemetry.api import urls as telemetry_urls
from telemetry.api.boat import TelemetryView

admin.site.site_header = "Shoreside"
admin.site.site_title = "Shoreside"
admin.site.index_title = "Fleet"

api_v1 = [
    # The boat's telemetry post answers with its command list when it changed (one exchange
    # per period, docs/api.md): wired here, where both apps may be imported.
    path(
        "boat/telemetry/",
        TelemetryView.as_view(commands_exchange=commands_exchange),
        name="boat-telemetry",
    ),
    path("", include(telemetry_urls.urlpatterns)),
    path("", include(command_urls.urlpatterns)),
    path("", include(sms_urls.urlpatterns)),
    path("", include(sbd_urls.urlpatterns)),
    path("", include(alert_urls.urlpatterns)),
    path("fleet/overlays/", FleetOverlaysView.as_view(), name="fleet-overlays"),
    path("", include("audit.api.urls")),
    path("fleet/alerts/", FleetAlertsView.as_view(), name="fleet-alerts"),
    path("schema/", SchemaView.as_view(permission_classes=[IsAuthenticated]), name="schema"),
    path(
        "docs/",
        SpectacularSwaggerView.as_view(url_name="schema", permission_classes=[IsAuthenticated]),
        name="api-docs",
    ),
    # Last: the router's vessels/<slug>/ must not shadow the per-vessel paths above.
    path("", include("vessels.api.urls")),
]

urlpatterns = [
    path("admin/", admin.site.urls),
    path("api/v1/", include(api_v1)),
    # The original SPAB endpoints, by the paths its client was built with (docs/api.md).
    path("spab/", include(telemetry_urls.legacy_urlpatterns)),
    path("spab/", include(command_urls.legacy_urlpatterns)),
    path("", include("fleet.pages")),
]

# JSON (or a telemAck) instead of HTML error pages on the API and boat paths.
handler400 = "fleet.error_views.bad_request"
handler403 = "fleet.error_views.permission_denied"
handler404 = "fleet.error_views.page_not_found"
handler500 = "fleet.error_views.server_error"
