"""Command admin: queue through the catalog-validated form, cancel, read the transition log;
a command's page follows its state live (state_view, commands/command_live.js)."""

from __future__ import annotations

import json
from typing import Any

from django.conf import settings
from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import Http404, HttpRequest, JsonResponse
from django.urls import path
from django.utils.html import format_html

from commands.errors import CommandError
from commands.forms import CommandForm
from commands.lifecycle import FINAL, OPEN
from commands.models import Command, CommandEvent, Source
from commands.services import command_cancel, command_enqueue


def status_badge(status: str) -> str:
    """A status in its colour (commands/status.css, which the page must load): done green,
    failed red, the neutral ends grey. The command list, a command's page and the vessel's
    recent commands show it alike."""
    return format_html('<span class="command-status cmd-{}">{}</span>', status, status)


class CommandEventInline(admin.TabularInline):
    model = CommandEvent
    extra = 0
    can_delete = False
    fields = ["at", "from_status", "to_status", "actor", "detail"]
    readonly_fields = fields

    def has_add_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


def live_state(command: Command) -> dict[str, Any]:
    """What a command's page compares to see that it moved on: status and transitions."""
    return {
        "status": command.status,
        "events": command.events.count(),
        "unfinished": command.status not in {s.value for s in FINAL},
        "poll_s": settings.FLEET_MAP_POLL_S,
    }


@admin.register(Command)
class CommandAdmin(admin.ModelAdmin):
    form = CommandForm
    # A command's page carries #command-live (its state URL, status and poll period) for
    # commands/command_live.js, which redraws the page while the command is unfinished.
    change_form_template = "admin/commands/command/change_form.html"
    list_display = [
        "created_at",
        "vessel",
        "kind",
        "params_summary",
        "status_badge",
        "source",
        "created_by",
    ]
    list_filter = ["status", "kind", "source", "vessel"]
    list_select_related = ["vessel"]
    search_fields = ["=uid", "created_by", "vessel__slug"]
    actions = ["cancel"]
    readonly_fields = [
        "uid",
        "vessel",
        "kind",
        "params_pretty",
        "status_badge",
        "source",
        "created_by",
        "created_at",
        "expires_at",
        "sent_at",
        "acknowledged_at",
        "finished_at",
        "result_detail",
        "urgent",
        "relay",
        "relayed_at",
    ]

    class Media:
        js = ["commands/command_form.js", "commands/command_live.js"]
        css = {"all": ["commands/status.css"]}

    def get_urls(self) -> list[Any]:
        state = self.admin_site.admin_view(self.state_view)
        return [
            path("<path:object_id>/state/", state, name="commands_command_state"),
            *super().get_urls(),
        ]

    def state_view(self, request: HttpRequest, object_id: str) -> JsonResponse:
        """Where a command stands, for its page to follow (commands/command_live.js): its
        status, how many transitions it has had, and whether it can still change."""
        command = self.get_object(request, object_id)
        if command is None or not self.has_view_permission(request, command):
            raise Http404
        return JsonResponse(live_state(command))

    def change_view(
        self,
        request: HttpRequest,
        object_id: str,
        form_url: str = "",
        extra_context: dict[str, Any] | None = None,
    ) -> Any:
        command = self.get_object(request, object_id)
        extra = dict(extra_context or {})
        if command is not None:
            extra["live_state"] = live_state(command)
        return super().change_view(request, object_id, form_url, extra)

    def get_inlines(self, request: HttpRequest, obj: Command | None) -> list[Any]:
        return [CommandEventInline] if obj else []

    def get_fields(self, request: HttpRequest, obj: Command | None = None) -> Any:
        if obj is not None:
            return self.readonly_fields
        form = CommandForm()
        return [
            "vessel",
            "kind",
            *[n for names in form.param_fields.values() for n in names],
            "mission",
            "expires_at",
            "urgent",
        ]

    def get_readonly_fields(self, request: HttpRequest, obj: Command | None = None) -> Any:
        return self.readonly_fields if obj else []

    def get_form(
        self, request: HttpRequest, obj: Any = None, change: bool = False, **kwargs: Any
    ) -> Any:
        if obj is not None:
            kwargs["form"] = admin.ModelAdmin.form
            kwargs["fields"] = []
        else:
            # The parameter fields are added by CommandForm.__init__ from the catalog; the
            # model form factory must only be given real model fields.
            kwargs["fields"] = CommandForm.Meta.fields
        return super().get_form(request, obj, change, **kwargs)

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        # Commands are never edited; only queued (add) or cancelled (action).
        return obj is None and super().has_change_permission(request, obj)

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        # Deleting would erase the transition history (logs stay, read-only: docs/operating.md).
        return False

    def save_model(self, request: HttpRequest, obj: Command, form: Any, change: bool) -> None:
        created = command_enqueue(
            vessel=form.cleaned_data["vessel"],
            kind=form.cleaned_data["kind"],
            params=form.cleaned_data["params"],
            source=Source.ADMIN,
            created_by=request.user.get_username(),
            expires_at=form.cleaned_data.get("expires_at"),
            urgent=form.cleaned_data.get("urgent", False),
        )
        for field in Command._meta.concrete_fields:
            setattr(obj, field.attname, getattr(created, field.attname))

    @admin.display(description="status", ordering="status")
    def status_badge(self, command: Command) -> str:
        """The status in its colour (commands/status.css): done green, failed red, the
        neutral ends grey (superseded: the boat or the queue replaced it with a newer one)."""
        return status_badge(command.status)

    @admin.display(description="params")
    def params_summary(self, command: Command) -> str:
        if isinstance(command.params.get("fences"), list):  # the fence set: by name
            fences = command.params["fences"]
            names = ", ".join(str(f.get("name") or "?") for f in fences if isinstance(f, dict))
            return f"{len(fences)} fence(s): {names}"[:80]
        text = ", ".join(f"{k}={v}" for k, v in command.params.items() if k != "items")
        if "items" in command.params:
            text = f"{len(command.params['items'])} waypoints" + (f", {text}" if text else "")
        return text[:80]

    @admin.display(description="params")
    def params_pretty(self, command: Command) -> str:
        return json.dumps(command.params, indent=1)

    @admin.action(description="Cancel selected commands", permissions=["cancel"])
    def cancel(self, request: HttpRequest, queryset: QuerySet[Command]) -> None:
        done = 0
        for command in queryset.filter(status__in=[s.value for s in OPEN]):
            try:
                command_cancel(command=command, actor=request.user.get_username())
                done += 1
            except CommandError as exc:  # it moved on (acknowledged, done) meanwhile
                messages.warning(request, f"{command.uid}: {exc.message}")
        skipped = queryset.count() - done
        messages.success(
            request,
            f"Cancelled {done} command(s)"
            + (f"; {skipped} were no longer open." if skipped else "."),
        )

    def has_cancel_permission(self, request: HttpRequest) -> bool:
        return request.user.has_perm("commands.change_command")
