"""Command endpoints: the boat's poll and ack and the operator's commands under /api/v1/;
requestCommands.cgi under /spab/ (``legacy_urlpatterns``)."""

from __future__ import annotations

from django.urls import path

from commands.api import boat, missions, operator
from commands.api.legacy import LegacyCommandsView

urlpatterns = [
    path("boat/commands/", boat.CommandListView.as_view(), name="boat-commands"),
    path("boat/commands/report/", boat.CommandReportView.as_view(), name="boat-commands-report"),
    path("boat/commands/<str:uid>/ack/", boat.AckView.as_view(), name="boat-ack"),
    path(
        "vessels/<slug:slug>/commands/",
        operator.VesselCommandsView.as_view(),
        name="vessel-commands",
    ),
    path("commands/<str:uid>/cancel/", operator.CommandCancelView.as_view(), name="command-cancel"),
    path("missions/<int:pk>/send/", missions.MissionSendView.as_view(), name="mission-send"),
]

legacy_urlpatterns = [
    path("requestCommands.cgi", LegacyCommandsView.as_view(), name="legacy-commands"),
]
