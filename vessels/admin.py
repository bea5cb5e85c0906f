"""Vessel, key and mission admin. Every write goes through vessels.services.

The vessel page's recent fixes and commands and the mission's "send" action join other apps:
fleet.admin adds them where the admin site is assembled."""

from __future__ import annotations

import json
from typing import Any

from django import forms
from django.contrib import admin, messages
from django.core.exceptions import PermissionDenied
from django.db import models
from django.db.models import QuerySet
from django.http import Http404, HttpRequest, HttpResponse, JsonResponse
from django.shortcuts import redirect
from django.template.response import TemplateResponse
from django.urls import path, reverse
from django.utils import timezone
from django.utils.html import format_html, format_html_join

from vessels import missionfiles
from vessels.display import fmt_ddm, fmt_position, fmt_speed
from vessels.errors import MissionFileError
from vessels.missions import (
    DEFAULT_CRUISE_SPEED_MPS,
    ENDS,
    ITEM_FIELDS,
    MISSION_MAX_ITEMS,
    item_problems,
)
from vessels.models import Mission, MissionItem, Vessel, VesselKey
from vessels.selectors import missions_visible_to
from vessels.services import (
    mission_export,
    mission_import,
    mission_review,
    mission_route_problems,
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
    search_fields = ["name", "slug", "imei"]
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
        (
            None,
            {
                "fields": [
                    "name",
                    "slug",
                    "kind",
                    "active",
                    "telemetry_period_s",
                    "cruise_speed_mps",
                    "move_to_max_m",
                    "imei",
                    "sms_number",
                    "notes",
                ]
            },
        ),
        (
            "State",
            {"fields": ["status_badge", "last_seen_at", "last_fix_at", "position", "battery"]},
        ),
        ("Keys", {"fields": ["issue_key_link"]}),
        ("Compact telemetry", {"fields": ["compact_channels"], "classes": ["collapse"]}),
        (
            "Link budgets",
            {"fields": ["sbd_daily_credit_budget", "sms_daily_budget", "http_daily_budget_kb"]},
        ),
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
        # Decimal degrees; the chart form (degrees, decimal minutes) on hover.
        return format_html(
            '<span title="{}">{}</span>',
            fmt_ddm(fix["lat"], fix["lon"]),
            fmt_position(fix["lat"], fix["lon"]),
        )

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
    # A plain tabular inline: the mission planner map (fleet) edits these rows from script.
    model = MissionItem
    extra = 3
    fields = ["seq", "lat", "lon", "hold_s", "radius_m", "speed_mps"]
    # mission_save_items refuses more; the formset says so on the page instead of failing.
    max_num = MISSION_MAX_ITEMS

    def get_formset(self, request: HttpRequest, obj: Any = None, **kwargs: Any) -> Any:
        return super().get_formset(request, obj, validate_max=True, **kwargs)

    # Narrow number boxes: the admin's default width puts the last columns off screen.
    formfield_overrides = {
        models.FloatField: {
            "widget": forms.NumberInput(attrs={"step": "any", "style": "width:8em"})
        },
        models.PositiveIntegerField: {"widget": forms.NumberInput(attrs={"style": "width:4em"})},
    }


def _vessels_visible_to(user: Any) -> QuerySet[Vessel]:
    # The rule of vessels.selectors.missions_visible_to: without the right to see vessels, a
    # mission can only be a template, and no vessel's name or position reaches the page.
    if not user.has_perm("vessels.view_vessel"):
        return Vessel.objects.none()
    return Vessel.objects.all()


class MissionImportForm(forms.Form):
    file = forms.FileField(help_text="QGroundControl .plan, Mission Planner .waypoints or GeoJSON.")
    vessel = forms.ModelChoiceField(
        Vessel.objects.none(), required=False, help_text="Empty: a template any vessel can run."
    )
    name = forms.CharField(max_length=100, required=False, help_text="Empty: the file's own name.")
    skip_unsupported = forms.BooleanField(
        required=False,
        help_text="Import the rest when the file holds items a mission cannot (each one is "
        "listed); otherwise such a file is refused.",
    )

    def __init__(self, *args: Any, user: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.fields["vessel"].queryset = _vessels_visible_to(user)


@admin.register(Mission)
class MissionAdmin(admin.ModelAdmin):
    # The planner map over the item rows (template + vessels/static/vessels/planner.js).
    change_form_template = "admin/vessels/mission/change_form.html"
    list_display = ["name", "vessel", "item_count", "end", "updated_at"]
    list_filter = ["vessel", "end"]
    inlines = [MissionItemInline]
    fields = ["name", "vessel", "end", "home_lat", "home_lon", "notes", "route", "export_links"]
    readonly_fields = ["route", "export_links"]

    def get_queryset(self, request: HttpRequest) -> QuerySet[Mission]:
        return missions_visible_to(request.user)

    def get_list_filter(self, request: HttpRequest) -> Any:
        # The vessel filter lists every vessel's name.
        if not request.user.has_perm("vessels.view_vessel"):
            return [f for f in self.list_filter if f != "vessel"]
        return self.list_filter

    def formfield_for_foreignkey(self, db_field: Any, request: HttpRequest, **kwargs: Any) -> Any:
        if db_field.name == "vessel":
            kwargs["queryset"] = _vessels_visible_to(request.user)
        return super().formfield_for_foreignkey(db_field, request, **kwargs)

    def get_urls(self) -> list[Any]:
        view = self.admin_site.admin_view
        return [
            path("import/", view(self.import_view), name="vessels_mission_import"),
            path("review/", view(self.review_view), name="vessels_mission_review"),
            path(
                "<int:pk>/export/<str:format>/",
                view(self.export_view),
                name="vessels_mission_export",
            ),
            *super().get_urls(),
        ]

    @admin.display(description="waypoints")
    def item_count(self, mission: Mission) -> int:
        return mission.items.count()

    @admin.display(description="route")
    def route(self, mission: Mission) -> str:
        if mission.pk is None:
            return "–"
        # The planner shows the same review (ReviewView), so the two never disagree.
        review = mission_review(mission=mission)
        speed = mission.vessel.cruise_speed_mps if mission.vessel else DEFAULT_CRUISE_SPEED_MPS
        rows = format_html_join(
            "",
            '<tr class="{}"><td>{} → {}</td><td>{}</td><td>{}°</td><td>{}</td><td>{}</td>'
            "<td>{}</td></tr>",
            (
                (
                    "leg-problem" if leg["problem"] else "",
                    leg["from"],
                    leg["to"],
                    leg["distance"],
                    f"{leg['bearing_deg']:.0f}",
                    fmt_speed(leg["speed_mps"]),
                    leg["time"],
                    leg["problem"] or "",
                )
                for leg in review["legs"]
            ),
        )
        return format_html(
            '<table id="mission-route"><tr><th>leg</th><th>distance</th><th>bearing</th>'
            "<th>speed</th><th>time</th><th></th></tr>{}</table>"
            '<p><b id="mission-route-total">{}</b> (at a cruise speed of {} unless an item '
            "sets its own)</p>",
            rows,
            review["total"],
            fmt_speed(speed),
        )

    @admin.display(description="export")
    def export_links(self, mission: Mission) -> str:
        if mission.pk is None:
            return "–"
        return format_html_join(
            " ",
            '<a class="button" href="{}" download>{}</a>',
            (
                (reverse("admin:vessels_mission_export", args=[mission.pk, fmt]), label)
                for fmt, label in EXPORT_LABELS.items()
            ),
        )

    def send_problems(self, mission: Mission) -> list[str]:
        """What would stop this mission being sent; fleet.admin adds the catalog's checks."""
        return mission_route_problems(mission=mission)

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
        for problem in self.send_problems(form.instance):
            messages.warning(request, f"Saved, but it cannot be sent yet: {problem}.")

    def construct_change_message(
        self, request: HttpRequest, form: Any, formsets: Any, add: bool
    ) -> Any:
        # The item formsets were not saved as formsets (mission_save_items wrote the rows).
        return super().construct_change_message(request, form, [], add)

    def import_view(self, request: HttpRequest) -> HttpResponse:
        if not self.has_add_permission(request):
            raise PermissionDenied
        too_big = None
        if request.method == "POST":
            # Before request.FILES: the view would otherwise take the whole upload first.
            try:
                missionfiles.check_request_size(request.META.get("CONTENT_LENGTH"))
            except MissionFileError as exc:
                too_big = exc.message
        if too_big:
            # An unbound form (the body stays unread) showing the error on its file field.
            form = MissionImportForm(user=request.user)
            form.errors["file"] = form.error_class([too_big])
        else:
            form = MissionImportForm(request.POST or None, request.FILES or None, user=request.user)
        if request.method == "POST" and not too_big and form.is_valid():
            upload = form.cleaned_data["file"]
            try:
                missionfiles.check_size(upload.size)
                mission, skipped = mission_import(
                    content=upload.read(),
                    filename=upload.name,
                    vessel=form.cleaned_data["vessel"],
                    name=form.cleaned_data["name"],
                    skip_unsupported=form.cleaned_data["skip_unsupported"],
                )
            except MissionFileError as exc:
                for problem in exc.problems:
                    form.add_error("file", problem)
            else:
                count = mission.items.count()
                messages.success(request, f"Imported {mission.name}: {count} waypoint(s).")
                for item in skipped:
                    messages.warning(request, f"Skipped {item}")
                # Kept (it may be fixed on the page), but said at once, as a save says it.
                for problem in self.send_problems(mission):
                    messages.warning(request, f"Imported, but it cannot be sent yet: {problem}.")
                return redirect("admin:vessels_mission_change", mission.pk)
        context = {
            **self.admin_site.each_context(request),
            "opts": self.model._meta,
            "title": "Import a mission file",
            "form": form,
        }
        return TemplateResponse(request, "admin/vessels/mission/import.html", context)

    def review_view(self, request: HttpRequest) -> HttpResponse:
        """The planner's figures and checks for the route on screen (not saved): POST
        ``{"rows": [{lat, lon, hold_s, radius_m, speed_mps}], "end", "home", "vessel"}``,
        answered with vessels.missions.review. Writes nothing."""
        if request.method != "POST":
            return JsonResponse({"detail": "POST the route"}, status=405)
        if not self.has_view_permission(request):
            raise PermissionDenied
        try:
            route = _planner_route(json.loads(request.body), user=request.user)
        except RecursionError:  # nested past the JSON parser's depth: no route is
            return JsonResponse({"detail": "not a route: nested too deeply"}, status=400)
        except (ValueError, TypeError) as exc:
            return JsonResponse({"detail": f"not a route: {exc}"}, status=400)
        review = mission_review(mission=Mission(end=route["end"]), **route)
        return JsonResponse(review)

    def export_view(self, request: HttpRequest, pk: int, format: str) -> HttpResponse:
        mission = self.get_object(request, str(pk))
        if mission is None or not self.has_view_permission(request, mission):
            raise Http404
        if format not in EXPORT_LABELS:
            raise Http404
        content, content_type, filename = mission_export(mission=mission, format=format)
        response = HttpResponse(content, content_type=content_type)
        response["Content-Disposition"] = f'attachment; filename="{filename}"'
        return response


def _planner_route(data: Any, *, user: Any) -> dict[str, Any]:
    """The planner's route from its JSON, for mission_review; ValueError/TypeError if not one.
    A value that is not a number stays as it is: missions.item_problems names it."""
    if not isinstance(data, dict) or not isinstance(data.get("rows"), list):
        raise ValueError("expected an object with a list of rows")
    if len(data["rows"]) > MISSION_MAX_ITEMS:
        raise ValueError(f"at most {MISSION_MAX_ITEMS} rows")
    if not all(isinstance(row, dict) for row in data["rows"]):
        raise ValueError("each row is an object")
    rows = [{name: row.get(name) for name in ITEM_FIELDS} for row in data["rows"]]
    end = data.get("end") if data.get("end") in ENDS else "stop"
    home = data.get("home")
    valid_home = (
        isinstance(home, list)
        and len(home) == 2
        and not item_problems({"lat": home[0], "lon": home[1]})
    )
    vessel_id = data.get("vessel")
    vessel = None
    if isinstance(vessel_id, int | str) and str(vessel_id).isdigit():
        vessel = _vessels_visible_to(user).filter(pk=int(vessel_id)).first()
    return {
        "rows": rows,
        "end": end,
        "home": (float(home[0]), float(home[1])) if valid_home else None,
        "vessel": vessel,
    }


EXPORT_LABELS = {
    "plan": "QGroundControl .plan",
    "waypoints": "Mission Planner .waypoints",
    "geojson": "GeoJSON",
}
