"""The fences' admin: draw a polygon or a circle on a map (Leaflet.draw, which django-leaflet
ships; alerts/static/alerts/fence_editor.js fills the geometry field), import a QGC `.plan`'s
geoFence or a GeoJSON file, and send fences to their vessels' autopilots.

Registered from alerts rather than vessels: the send action queues commands, and alerts sits
above vessels and commands (docs/architecture.md)."""

from __future__ import annotations

from typing import Any

from django import forms
from django.contrib import admin, messages
from django.core.exceptions import PermissionDenied
from django.db.models import QuerySet
from django.http import HttpRequest, HttpResponse
from django.shortcuts import redirect
from django.template.response import TemplateResponse
from django.urls import path

from commands.errors import CommandError
from commands.models import Source
from commands.services import fence_send
from vessels import missionfiles
from vessels.errors import VesselsError
from vessels.fence_services import (
    FENCE_FIELDS,
    fence_create,
    fence_delete,
    fence_import,
    fence_update,
)
from vessels.models import Fence, Vessel, VesselKind
from vessels.selectors import fences_visible_to


def _vessels_visible_to(user: Any) -> QuerySet[Vessel]:
    return Vessel.objects.all() if user.has_perm("vessels.view_vessel") else Vessel.objects.none()


class FenceForm(forms.ModelForm):
    geometry = forms.JSONField(
        widget=forms.Textarea(attrs={"rows": 3, "class": "fence-geometry"}),
        help_text="Drawn on the map above, or GeoJSON pasted here: a closed Polygon "
        "([longitude, latitude] pairs), or a Point with a radius.",
    )

    class Meta:
        model = Fence
        fields = list(FENCE_FIELDS)
        widgets = {"radius_m": forms.NumberInput(attrs={"step": "any", "class": "fence-radius"})}


class FenceImportForm(forms.Form):
    file = forms.FileField(help_text="A QGroundControl .plan (its GeoFence) or a GeoJSON file.")
    vessel = forms.ModelChoiceField(
        Vessel.objects.none(), required=False, help_text="Empty: fences every vessel keeps."
    )
    name = forms.CharField(
        max_length=90, required=False, help_text="Empty: the file's own names, else its name."
    )

    def __init__(self, *args: Any, user: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.fields["vessel"].queryset = _vessels_visible_to(user)


@admin.register(Fence)
class FenceAdmin(admin.ModelAdmin):
    form = FenceForm
    change_form_template = "admin/alerts/fence/change_form.html"
    change_list_template = "admin/alerts/fence/change_list.html"
    list_display = ["name", "vessel", "kind_shown", "shape", "updated_at"]
    list_filter = ["inclusion", "vessel"]
    search_fields = ["name", "notes"]
    list_select_related = ["vessel"]
    actions = ["send_to_vessel"]

    def get_queryset(self, request: HttpRequest) -> QuerySet[Fence]:
        return fences_visible_to(request.user)

    def formfield_for_foreignkey(self, db_field: Any, request: HttpRequest, **kwargs: Any) -> Any:
        if db_field.name == "vessel":
            kwargs["queryset"] = _vessels_visible_to(request.user)
        return super().formfield_for_foreignkey(db_field, request, **kwargs)

    @admin.display(description="kind", ordering="inclusion")
    def kind_shown(self, fence: Fence) -> str:
        return "stay inside" if fence.inclusion else "stay out"

    @admin.display(description="shape")
    def shape(self, fence: Fence) -> str:
        return fence.shape

    def get_urls(self) -> list[Any]:
        view = self.admin_site.admin_view(self.import_view)
        return [path("import/", view, name="vessels_fence_import"), *super().get_urls()]

    def _who(self, request: HttpRequest) -> dict[str, Any]:
        return {
            "by": request.user.get_username(),
            "via": "admin",
            "ip": request.META.get("REMOTE_ADDR"),
        }

    def save_model(self, request: HttpRequest, obj: Fence, form: Any, change: bool) -> None:
        fields = {
            name: form.cleaned_data[name] for name in FENCE_FIELDS if name in form.cleaned_data
        }
        if change:
            saved = fence_update(
                fence=Fence.objects.get(pk=obj.pk), fields=fields, **self._who(request)
            )
        else:
            saved = fence_create(**fields, **self._who(request))
        obj.pk = saved.pk

    def delete_model(self, request: HttpRequest, obj: Fence) -> None:
        fence_delete(fence=obj, **self._who(request))

    def delete_queryset(self, request: HttpRequest, queryset: QuerySet[Fence]) -> None:
        for fence in queryset:
            self.delete_model(request, fence)

    def has_send_permission(self, request: HttpRequest) -> bool:
        # As the API's send: queuing a command for a vessel needs the right to see vessels.
        user = request.user
        return user.has_perm("commands.add_command") and user.has_perm("vessels.view_vessel")

    @admin.action(description="Send fence to vessel", permissions=["send"])
    def send_to_vessel(self, request: HttpRequest, queryset: QuerySet[Fence]) -> None:
        """Queue each fence as a `fence` command for its vessel; a fence every vessel keeps
        goes to every active ArduPilot vessel (the kind that has an autopilot fence)."""
        everyone = list(Vessel.objects.filter(active=True, kind=VesselKind.MAVLINK))
        who = request.user.get_username()
        for fence in queryset:
            for vessel in [fence.vessel] if fence.vessel_id else everyone:
                try:
                    command = fence_send(
                        fence=fence, vessel=vessel, created_by=who, source=Source.ADMIN
                    )
                except CommandError as exc:
                    messages.error(request, f"{fence} → {vessel}: {exc.message}")
                    continue
                messages.success(request, f"{fence} → {vessel}: queued as command {command.uid}.")

    def import_view(self, request: HttpRequest) -> HttpResponse:
        if not self.has_add_permission(request):
            raise PermissionDenied
        form = FenceImportForm(request.POST or None, request.FILES or None, user=request.user)
        if request.method == "POST" and form.is_valid():
            upload = form.cleaned_data["file"]
            try:
                missionfiles.check_size(upload.size)
                created = fence_import(
                    content=upload.read(), filename=upload.name or "",
                    vessel=form.cleaned_data["vessel"], name=form.cleaned_data["name"],
                    **self._who(request),
                )  # fmt: skip
            except VesselsError as exc:
                for problem in exc.problems:
                    form.add_error("file", problem)
            else:
                names = ", ".join(f.name for f in created)
                messages.success(request, f"Imported {len(created)} fence(s): {names}.")
                return redirect("admin:vessels_fence_changelist")
        context = {
            **self.admin_site.each_context(request),
            "opts": self.model._meta,
            "title": "Import fences from a file",
            "form": form,
        }
        return TemplateResponse(request, "admin/alerts/fence/import.html", context)
