"""Admin pages that join several apps, assembled at the top of the stack (DESIGN §2).

The vessel page gains its recent fixes and commands, the mission list its "send to vessel"
action; the apps' own admins stay within their app and never import the apps above them.
"""

from __future__ import annotations

from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import HttpRequest
from django.urls import reverse
from django.utils.html import format_html, format_html_join

from commands.admin import CommandAdmin
from commands.errors import CommandError
from commands.models import Command, Source
from commands.services import mission_problems, mission_send
from sms.models import SmsMessage
from telemetry.models import Fix
from vessels.admin import MissionAdmin, VesselAdmin
from vessels.models import Mission, Vessel

RECENT_ROWS = 15


class FleetVesselAdmin(VesselAdmin):
    readonly_fields = [*VesselAdmin.readonly_fields, "recent_fixes", "recent_commands"]
    fieldsets = [
        *VesselAdmin.fieldsets,
        ("Recent activity", {"fields": ["recent_fixes", "recent_commands"]}),
    ]

    @admin.display(description="recent fixes")
    def recent_fixes(self, vessel: Vessel) -> str:
        fixes = Fix.objects.filter(vessel=vessel).order_by("-recorded_at")[:RECENT_ROWS]
        rows = format_html_join(
            "",
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            (  # formatted here: format_html escapes its arguments to strings first
                (
                    f.recorded_at.strftime("%Y-%m-%d %H:%M:%S"),
                    f"{f.lat:.5f}",
                    f"{f.lon:.5f}",
                    "–" if f.speed_mps is None else f"{f.speed_mps:.1f}",
                    "–" if f.battery_v is None else f"{f.battery_v:.2f}",
                )
                for f in fixes
            ),
        )
        return format_html(
            "<table><tr><th>time (UTC)</th><th>lat</th><th>lon</th><th>speed m/s</th>"
            "<th>battery V</th></tr>{}</table>",
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
                    c.created_at.strftime("%Y-%m-%d %H:%M:%S"),
                    reverse("admin:commands_command_change", args=[c.pk]),
                    c.kind,
                    c.status,
                    c.get_source_display(),
                    c.result_detail[:80],
                )
                for c in commands
            ),
        )
        link = reverse("admin:commands_command_add") + f"?vessel={vessel.pk}"
        return format_html(
            "<table><tr><th>created (UTC)</th><th>kind</th><th>status</th><th>source</th>"
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

    def mission_problems(self, mission: Mission) -> list[str]:
        # The whole set of checks a send makes: the catalog's (vessel kind, autopilot size)
        # and the route's; vessels.admin alone knows only the route's.
        return mission_problems(mission=mission)

    @admin.action(description="Send selected missions to their vessel", permissions=["send"])
    def send_to_vessel(self, request: HttpRequest, queryset: QuerySet[Mission]) -> None:
        for mission in queryset:
            try:
                command = mission_send(
                    mission=mission, source=Source.ADMIN, created_by=request.user.get_username()
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
