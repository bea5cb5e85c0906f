"""Vessel, key and mission admin. Every write goes through vessels.services.

The vessel page's recent fixes and commands and the mission's "send" action join other apps:
fleet.admin adds them where the admin site is assembled."""

from __future__ import annotations

from typing import Any

from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import HttpRequest, HttpResponse
from django.template.response import TemplateResponse
from django.urls import reverse
from django.utils import timezone
from django.utils.html import format_html

from vessels.models import Mission, MissionItem, Vessel, VesselKey
from vessels.services import (
    mission_save,
    mission_save_items,
    vessel_key_issue,
    vessel_key_revoke,
    vessel_save,
)


class StatusFilter(admin.SimpleListFilter):
    title = "status"
    parameter_name = "status"

    def lookups(self, request: HttpRequest, model_admin: Any) -> list[tuple[str, str]]:
        return [("reporting", "Reporting"), ("overdue", "Overdue"), ("never seen", "Never seen")]

    def queryset(self, request: HttpRequest, queryset: QuerySet[Vessel]) -> QuerySet[Vessel]:
        if not self.value():
            return queryset
        # Each vessel has its own period, and fleets are small: decide in Python.
        now = timezone.now()
        return queryset.filter(pk__in=[v.pk for v in queryset if v.status(now) == self.value()])


def _status_badge(vessel: Vessel) -> str:
    status = vessel.status(timezone.now())
    colour = {"reporting": "#2e7d32", "overdue": "#c62828", "never seen": "#757575"}[status]
    return format_html('<b style="color:{}">{}</b>', colour, status)


class VesselKeyInline(admin.TabularInline):
    model = VesselKey
    extra = 0
    can_delete = False
    fields = ["prefix", "label", "created_at", "created_by", "last_used_at", "revoked_at"]
    readonly_fields = fields
    show_change_link = True

    def has_add_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


@admin.register(Vessel)
class VesselAdmin(admin.ModelAdmin):
    list_display = [
        "name",
        "slug",
        "kind",
        "status_badge",
        "last_fix_at",
        "position",
        "battery",
        "active",
    ]
    list_filter = [StatusFilter, "kind", "active"]
    search_fields = ["name", "slug"]
    prepopulated_fields = {"slug": ["name"]}
    inlines = [VesselKeyInline]
    readonly_fields = [
        "status_badge",
        "last_fix_at",
        "last_seen_at",
        "position",
        "battery",
        "issue_key_link",
        "activity_links",
    ]
    fieldsets = [
        (None, {"fields": ["name", "slug", "kind", "active", "telemetry_period_s", "notes"]}),
        (
            "State",
            {"fields": ["status_badge", "last_seen_at", "last_fix_at", "position", "battery"]},
        ),
        ("Keys", {"fields": ["issue_key_link"]}),
        ("Activity", {"fields": ["activity_links"]}),
    ]

    def get_fieldsets(self, request: HttpRequest, obj: Vessel | None = None) -> Any:
        return self.fieldsets if obj else self.fieldsets[:1]

    def get_inlines(self, request: HttpRequest, obj: Vessel | None) -> list[Any]:
        return self.inlines if obj else []

    # The slug is the vessel's stable id: boats (legacy Basic auth) and URLs use it.
    def get_readonly_fields(self, request: HttpRequest, obj: Vessel | None = None) -> Any:
        return [*self.readonly_fields, "slug"] if obj else self.readonly_fields

    def get_prepopulated_fields(self, request: HttpRequest, obj: Vessel | None = None) -> Any:
        return {} if obj else self.prepopulated_fields

    def save_model(self, request: HttpRequest, obj: Vessel, form: Any, change: bool) -> None:
        vessel_save(vessel=obj)

    @admin.display(description="status")
    def status_badge(self, vessel: Vessel) -> str:
        return _status_badge(vessel)

    @admin.display(description="position")
    def position(self, vessel: Vessel) -> str:
        fix = vessel.last_fix or {}
        if "lat" not in fix:
            return "–"
        return f"{fix['lat']:.5f}, {fix['lon']:.5f}"

    @admin.display(description="battery (V)")
    def battery(self, vessel: Vessel) -> str:
        value = vessel.battery_v
        return "–" if value is None else f"{value:.2f}"

    @admin.display(description="fixes and commands")
    def activity_links(self, vessel: Vessel) -> str:
        # By URL name only: telemetry and commands sit above vessels, which never imports them.
        fixes = reverse("admin:telemetry_fix_changelist") + f"?vessel={vessel.pk}"
        commands = reverse("admin:commands_command_changelist") + f"?vessel__id__exact={vessel.pk}"
        return format_html(
            '<a href="{}">All fixes</a> · <a href="{}">All commands</a>', fixes, commands
        )

    @admin.display(description="new key")
    def issue_key_link(self, vessel: Vessel) -> str:
        url = reverse("admin:vessels_vesselkey_add") + f"?vessel={vessel.pk}"
        return format_html('<a class="button" href="{}">Issue a new key</a>', url)


@admin.register(VesselKey)
class VesselKeyAdmin(admin.ModelAdmin):
    list_display = ["prefix", "vessel", "label", "created_at", "last_used_at", "revoked_at"]
    list_filter = ["vessel", ("revoked_at", admin.EmptyFieldListFilter)]
    list_select_related = ["vessel"]
    actions = ["revoke"]

    def get_fields(self, request: HttpRequest, obj: VesselKey | None = None) -> list[str]:
        if obj is None:
            return ["vessel", "label"]
        return [
            "vessel",
            "label",
            "prefix",
            "created_at",
            "created_by",
            "last_used_at",
            "revoked_at",
        ]

    def get_readonly_fields(self, request: HttpRequest, obj: VesselKey | None = None) -> Any:
        return self.get_fields(request, obj) if obj else []

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        # Keys are issued and revoked, never edited; the revoke action needs this permission.
        return obj is None and super().has_change_permission(request, obj)

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        # Revoke (a service) instead: a deleted key takes its usage record with it.
        return False

    def save_model(self, request: HttpRequest, obj: VesselKey, form: Any, change: bool) -> None:
        key, raw = vessel_key_issue(
            vessel=obj.vessel, label=obj.label, created_by=request.user.get_username()
        )
        obj.pk, obj.prefix, obj.key_hash, obj.created_at = (
            key.pk,
            key.prefix,
            key.key_hash,
            key.created_at,
        )
        request._issued_key = raw  # shown once by response_add, never stored

    def response_add(
        self, request: HttpRequest, obj: VesselKey, post_url_continue: Any = None
    ) -> HttpResponse:
        context = {
            **self.admin_site.each_context(request),
            "key": obj,
            "raw_key": request._issued_key,
        }
        response = TemplateResponse(request, "vessels/key_issued.html", context)
        response["Cache-Control"] = "no-store"
        return response

    @admin.action(description="Revoke selected keys", permissions=["change"])
    def revoke(self, request: HttpRequest, queryset: QuerySet[VesselKey]) -> None:
        for key in queryset:
            vessel_key_revoke(key=key)
        messages.success(request, f"Revoked {queryset.count()} key(s).")


class MissionItemInline(admin.TabularInline):
    model = MissionItem
    extra = 3
    fields = ["seq", "lat", "lon", "hold_s", "radius_m"]


@admin.register(Mission)
class MissionAdmin(admin.ModelAdmin):
    # The planner map over the item rows (template + vessels/static/vessels/planner.js).
    change_form_template = "admin/vessels/mission/change_form.html"
    list_display = ["name", "vessel", "item_count", "loop", "updated_at"]
    list_filter = ["vessel"]
    inlines = [MissionItemInline]

    @admin.display(description="waypoints")
    def item_count(self, mission: Mission) -> int:
        return mission.items.count()

    def save_model(self, request: HttpRequest, obj: Mission, form: Any, change: bool) -> None:
        mission_save(mission=obj)

    def save_related(self, request: HttpRequest, form: Any, formsets: Any, change: bool) -> None:
        form.save_m2m()
        items = []
        for formset in formsets:
            for row in formset.cleaned_data:
                if row and not row.get("DELETE"):
                    items.append(row)
        items.sort(key=lambda row: row["seq"])
        mission_save_items(mission=form.instance, items=items)

    def construct_change_message(
        self, request: HttpRequest, form: Any, formsets: Any, add: bool
    ) -> Any:
        # The item formsets were not saved as formsets (mission_save_items wrote the rows).
        return super().construct_change_message(request, form, [], add)
