"""Admin pages that join several apps, assembled at the top of the stack (docs/architecture.md).

The vessel page gains its recent fixes and commands, the mission list its "send to vessel"
action; the apps' own admins stay within their app and never import the apps above them.
"""

from __future__ import annotations

import json
from typing import Any

from django.contrib import admin, messages
from django.core.exceptions import PermissionDenied
from django.db.models import Count, Q, QuerySet
from django.http import Http404, HttpRequest, HttpResponse, HttpResponseNotAllowed
from django.shortcuts import redirect
from django.template.response import TemplateResponse
from django.urls import path, reverse
from django.utils.dateparse import parse_datetime
from django.utils.html import format_html, format_html_join

from alerts.admin import state_badge
from alerts.models import ACTIVE_STATES, Alert
from alerts.selectors import endurance_text, vessel_endurance_hours
from commands.admin import CommandAdmin, status_badge
from commands.errors import CommandError
from commands.models import Command, Source
from commands.services import mission_send, mission_send_problems
from fleet.relays import configured_senders
from fleet.routing import routing_summary
from links.display import links_html
from sms.models import SmsMessage
from telemetry.admin import channel_labels, readings_html
from telemetry.models import Fix
from vessels import missions
from vessels.admin import MissionAdmin, VesselAdmin
from vessels.display import fmt_ddm, fmt_position, fmt_speed, fmt_time
from vessels.models import Mission, Vessel
from vessels.services import mission_review

RECENT_ROWS = 15


class FleetVesselAdmin(VesselAdmin):
    readonly_fields = [
        *VesselAdmin.readonly_fields, "open_alerts", "battery_endurance", "recent_fixes",
        "recent_commands", "links",
    ]  # fmt: skip
    list_display = [*VesselAdmin.list_display[:4], "alerts_shown", *VesselAdmin.list_display[4:]]
    fieldsets = [
        VesselAdmin.fieldsets[0],
        ("Open alerts", {"fields": ["open_alerts", "battery_endurance"]}),
        *VesselAdmin.fieldsets[1:],
        ("Links", {"fields": ["links"]}),
        ("Recent activity", {"fields": ["recent_fixes", "recent_commands"]}),
    ]

    def get_queryset(self, request: HttpRequest) -> QuerySet[Vessel]:
        # The list's alert column, counted in the list's one query.
        active = Q(alerts__state__in=[s.value for s in ACTIVE_STATES])
        return super().get_queryset(request).annotate(active_alerts=Count("alerts", filter=active))

    @admin.display(description="alerts", ordering="active_alerts")
    def alerts_shown(self, vessel: Vessel) -> str:
        count = getattr(vessel, "active_alerts", 0)
        if not count:
            return "–"
        link = (
            reverse("admin:alerts_alert_changelist") + f"?active=yes&vessel__id__exact={vessel.pk}"
        )
        return format_html(
            '<a class="alert-count" href="{}" style="color:#c62828"><b>{}</b></a>', link, count
        )

    @admin.display(description="open alerts")
    def open_alerts(self, vessel: Vessel) -> str:
        alerts = (
            Alert.objects.filter(vessel=vessel, state__in=[s.value for s in ACTIVE_STATES])
            .select_related("rule")
            .order_by("-opened_at")
        )
        if not alerts:
            return "None."
        rows = format_html_join(
            "",
            '<tr><td class="nowrap">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>',
            (
                (fmt_time(a.opened_at), state_badge(a.state), a.rule.name, a.detail,
                 a.acknowledged_by and f"by {a.acknowledged_by}")
                for a in alerts
            ),
        )  # fmt: skip
        link = (
            reverse("admin:alerts_alert_changelist") + f"?active=yes&vessel__id__exact={vessel.pk}"
        )
        return format_html(
            '<table class="open-alerts"><tr><th>opened</th><th>state</th><th>rule</th>'
            "<th>detail</th><th>acknowledged</th></tr>{}</table>"
            '<a class="button" href="{}">Acknowledge on the alerts page</a>',
            rows,
            link,
        )

    @admin.display(description="battery endurance")
    def battery_endurance(self, vessel: Vessel) -> str:
        """As the endurance rules judge it (docs/alerts.md#battery-endurance)."""
        if vessel.pk is None:
            return "–"
        return endurance_text(vessel_endurance_hours(vessel=vessel))

    @admin.display(description="links")
    def links(self, vessel: Vessel) -> str:
        """What each transport carried and cost (links app), and where commands go now."""
        if vessel.pk is None:
            return "–"
        route = routing_summary(vessel, configured_senders())
        return format_html('<p class="routing">{}</p>{}', route, links_html(vessel.pk))

    class Media:
        css = {"all": ["commands/status.css"]}  # the recent commands' status badges

    @admin.display(description="recent fixes")
    def recent_fixes(self, vessel: Vessel) -> str:
        fixes = Fix.objects.filter(vessel=vessel).order_by("-recorded_at")[:RECENT_ROWS]
        labels = channel_labels()
        rows = format_html_join(
            "",
            '<tr><td class="nowrap">{}</td><td class="nowrap" title="{}">{}</td>'
            '<td class="nowrap">{}</td><td>{}</td></tr>',
            (  # formatted here: format_html escapes its arguments to strings first
                (
                    fmt_time(f.recorded_at),
                    fmt_ddm(f.lat, f.lon),
                    fmt_position(f.lat, f.lon),
                    fmt_speed(f.speed_mps),
                    readings_html(f, labels),
                )
                for f in fixes
            ),
        )
        return format_html(
            "<table><tr><th>time</th><th>position</th><th>speed</th><th>readings</th></tr>"
            "{}</table>",
            rows,
        )

    @admin.display(description="recent commands")
    def recent_commands(self, vessel: Vessel) -> str:
        commands = Command.objects.filter(vessel=vessel).order_by("-created_at")[:RECENT_ROWS]
        rows = format_html_join(
            "",
            '<tr><td>{}</td><td><a href="{}">{}</a></td><td>{}</td><td>{}</td><td>{}</td></tr>',
            (
                (
                    fmt_time(c.created_at),
                    reverse("admin:commands_command_change", args=[c.pk]),
                    c.kind,
                    status_badge(c.status),
                    c.get_source_display(),
                    c.result_detail[:80],
                )
                for c in commands
            ),
        )
        link = reverse("admin:commands_command_add") + f"?vessel={vessel.pk}"
        return format_html(
            "<table><tr><th>created</th><th>kind</th><th>status</th><th>source</th>"
            "<th>detail</th></tr>"
            '{}</table><a class="button" href="{}">Queue a command</a>',
            rows,
            link,
        )


class FleetMissionAdmin(MissionAdmin):
    actions = ["send_to_vessel"]

    def has_send_permission(self, request: HttpRequest) -> bool:
        # As the API's send: queuing a command for a vessel needs the right to see vessels.
        return request.user.has_perm("commands.add_command") and request.user.has_perm(
            "vessels.view_vessel"
        )

    def send_problems(self, mission: Mission) -> list[str]:
        # The whole set of checks a send makes: the catalog's (vessel kind, autopilot size)
        # and the route's; vessels.admin alone knows only the route's.
        return mission_send_problems(mission=mission)

    def get_urls(self) -> list[Any]:
        send = self.admin_site.admin_view(self.send_view)
        return [path("<int:pk>/send/", send, name="vessels_mission_send"), *super().get_urls()]

    def change_view(
        self,
        request: HttpRequest,
        object_id: str,
        form_url: str = "",
        extra_context: dict[str, Any] | None = None,
    ) -> HttpResponse:
        # The Send button's confirmation, from the saved mission: the page refuses to send
        # while the form differs from it, and send_view checks the same on the server.
        mission = self.get_object(request, object_id)
        extra = dict(extra_context or {})
        if mission is not None and mission.vessel and self.has_send_permission(request):
            extra["send_confirmation"] = self._send_summary(mission)
        return super().change_view(request, object_id, form_url, extra)

    @staticmethod
    def _send_summary(mission: Mission) -> str:
        """What an operator confirms before ``mission`` (one with a vessel) is sent."""
        fix = mission.vessel.last_fix or {}
        return missions.send_confirmation(
            mission_review(mission=mission),
            items=mission.item_dicts(),
            end=mission.end,
            vessel_name=mission.vessel.name,
            last_fix=(fix["lat"], fix["lon"]) if "lat" in fix else None,
        )

    def send_view(self, request: HttpRequest, pk: int) -> HttpResponse:
        """The mission page's Send: queues the mission only if the route the operator
        confirmed (``confirmed``, JSON, filled in by planner.js) is the one saved, then shows
        the command's page (live) to an operator who may see commands."""
        if request.method != "POST":
            return HttpResponseNotAllowed(["POST"])
        if not self.has_send_permission(request):
            raise PermissionDenied
        mission = self.get_object(request, str(pk))
        if mission is None:
            raise Http404
        try:
            confirmed = json.loads(request.POST.get("confirmed") or "null")
        except (ValueError, RecursionError):
            confirmed = None
        # The version the page showed: someone else's save since (another route, another
        # vessel) must not go out under this page's summary.
        shown_at = parse_datetime(request.POST.get("updated_at") or "")
        if shown_at is None:
            messages.error(
                request,
                f"{mission}: not sent: the page did not say which version of the mission it "
                "showed; reload it",
            )
            return redirect("admin:vessels_mission_change", mission.pk)
        try:
            command = mission_send(
                mission=mission,
                source=Source.ADMIN,
                created_by=request.user.get_username(),
                confirmed=confirmed,
                seen_at=shown_at,
            )
        except CommandError as exc:
            messages.error(request, f"{mission}: {exc.message}")
            return redirect("admin:vessels_mission_change", mission.pk)
        messages.success(request, f"{mission}: queued as command {command.uid}.")
        # The command's page, which follows it live (queued, sent, acknowledged, done), for
        # an operator who may see commands; the others stay on the mission.
        if request.user.has_perm("commands.view_command"):
            return redirect("admin:commands_command_change", command.pk)
        return redirect("admin:vessels_mission_change", mission.pk)

    @admin.action(description="Send selected missions to their vessel", permissions=["send"])
    def send_to_vessel(
        self, request: HttpRequest, queryset: QuerySet[Mission]
    ) -> HttpResponse | None:
        """Asks first, as the mission page's Send does: a page with each mission's summary
        (waypoints, distance, time, the boat's distance to waypoint 1, the end). Confirmed,
        it sends each mission as it was summed up; one saved since is not sent."""
        if request.POST.get("confirm") != "yes":
            rows = [(m, self._send_summary(m) if m.vessel else None) for m in queryset]
            return TemplateResponse(
                request,
                "admin/vessels/mission/send_confirm.html",
                {
                    **self.admin_site.each_context(request),
                    "title": "Send these missions?",
                    "opts": self.model._meta,
                    "rows": rows,
                    "action": "send_to_vessel",
                },
            )
        for mission in queryset:
            shown_at = parse_datetime(request.POST.get(f"updated_at_{mission.pk}") or "")
            if shown_at is None:
                messages.error(request, f"{mission}: not sent: it was not summed up")
                continue
            try:
                command = mission_send(
                    mission=mission,
                    source=Source.ADMIN,
                    created_by=request.user.get_username(),
                    seen_at=shown_at,
                )
            except CommandError as exc:
                messages.error(request, f"{mission}: {exc.message}")
                continue
            messages.success(request, f"{mission}: queued as command {command.uid}.")


class FleetCommandAdmin(CommandAdmin):
    """A command's page names the SMS that created it (commands must not import sms)."""

    readonly_fields = [*CommandAdmin.readonly_fields, "created_by_sms"]

    @admin.display(description="created by SMS")
    def created_by_sms(self, command: Command) -> str:
        messages_in = SmsMessage.objects.filter(commands=command, direction="in").order_by("pk")
        if not messages_in:
            return "–"
        return format_html_join(
            ", ",
            '<a href="{}">{}: {}</a>',
            (
                (
                    reverse("admin:sms_smsmessage_change", args=[m.pk]),
                    m.number_e164 or m.number,
                    m.text[:80],
                )
                for m in messages_in
            ),
        )


for model, model_admin in (
    (Vessel, FleetVesselAdmin),
    (Mission, FleetMissionAdmin),
    (Command, FleetCommandAdmin),
):
    admin.site.unregister(model)
    admin.site.register(model, model_admin)
