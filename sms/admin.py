"""SMS admin: authorised numbers (edited through the services) and the read-only SMS log."""

from __future__ import annotations

import json
from typing import Any

from django import forms
from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import HttpRequest
from django.urls import reverse
from django.utils.html import format_html, format_html_join
from django.utils.safestring import SafeString

from audit.admin import LogAdmin
from sms.errors import InvalidNumber
from sms.models import AuthorisedNumber, Direction, SmsMessage
from sms.services import (
    authorised_number_deauthorise,
    authorised_number_delete,
    authorised_number_save,
    number_normalise,
)
from telemetry.admin import CappedCountPaginator, VesselFilter
from vessels.display import fmt_time

TEXT_SHOWN = 160  # one SMS


class AuthorisedNumberForm(forms.ModelForm):
    class Meta:
        model = AuthorisedNumber
        fields = [
            "number", "name", "vessels", "role", "active", "expires_at", "receives_positions",
            "notes",
        ]  # fmt: skip

    def clean_number(self) -> str:
        # Normalised before the unique check, so "0412 345 678" finds "+61412345678".
        try:
            return number_normalise(raw=self.cleaned_data["number"])
        except InvalidNumber as exc:
            raise forms.ValidationError(exc.message) from None


@admin.register(AuthorisedNumber)
class AuthorisedNumberAdmin(admin.ModelAdmin):
    form = AuthorisedNumberForm
    list_display = [
        "number", "name", "role", "vessel_list", "active", "expires_at", "receives_positions",
    ]  # fmt: skip
    list_filter = ["role", "active", "receives_positions", "vessels"]
    search_fields = ["number", "name", "notes"]
    filter_horizontal = ["vessels"]
    actions = ["deauthorise"]
    readonly_fields = ["created_at", "updated_at"]

    def get_queryset(self, request: HttpRequest) -> QuerySet[AuthorisedNumber]:
        return super().get_queryset(request).prefetch_related("vessels")

    @admin.display(description="vessels")
    def vessel_list(self, entry: AuthorisedNumber) -> str:
        return ", ".join(v.slug for v in entry.vessels.all()) or "–"

    def save_model(
        self, request: HttpRequest, obj: AuthorisedNumber, form: Any, change: bool
    ) -> None:
        authorised_number_save(entry=obj, vessels=form.cleaned_data["vessels"])

    def save_related(self, request: HttpRequest, form: Any, formsets: Any, change: bool) -> None:
        # The vessels were set by authorised_number_save (the service owns every write).
        for formset in formsets:
            self.save_formset(request, form, formset, change=change)

    def delete_model(self, request: HttpRequest, obj: AuthorisedNumber) -> None:
        authorised_number_delete(entry=obj)

    def delete_queryset(self, request: HttpRequest, queryset: QuerySet[AuthorisedNumber]) -> None:
        for entry in queryset:
            authorised_number_delete(entry=entry)

    @admin.action(description="Deauthorise selected numbers", permissions=["change"])
    def deauthorise(self, request: HttpRequest, queryset: QuerySet[AuthorisedNumber]) -> None:
        for entry in queryset:
            authorised_number_deauthorise(entry=entry)
        messages.success(request, f"Deauthorised {queryset.count()} number(s).")


class RepliesInline(admin.TabularInline):
    model = SmsMessage
    fk_name = "reply_to"
    extra = 0
    can_delete = False
    verbose_name = "reply"
    verbose_name_plural = "replies"
    fields = ["created_at", "number", "text", "status", "status_detail", "reference", "sent_at"]
    readonly_fields = fields

    def has_add_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


@admin.register(SmsMessage)
class SmsMessageAdmin(LogAdmin):  # the log stays (docs/sms.md#the-sms-log)
    """The SMS log: every message in and out, read-only, fast on a long history."""

    list_display = [
        "when",
        "way",
        "vessel",
        "shown_number",
        "text_summary",
        "result",
    ]
    list_filter = ["direction", "outcome", "status", VesselFilter]
    list_select_related = ["vessel"]
    search_fields = ["number", "number_e164", "text"]
    ordering = ["-created_at", "-pk"]
    paginator = CappedCountPaginator
    show_full_result_count = False
    list_per_page = 100
    inlines = [RepliesInline]
    fields = [
        "direction",
        "vessel",
        "number",
        "number_e164",
        "authorised_number",
        "text",
        "authorised",
        "outcome",
        "detail",
        "parsed_pretty",
        "reply_link",
        "command_links",
        "modem_timestamp",
        "received_at",
        "created_at",
        "status",
        "status_detail",
        "reference",
        "sent_at",
    ]
    readonly_fields = fields

    @admin.display(description="time", ordering="-created_at")
    def when(self, message: SmsMessage) -> SafeString:
        return format_html('<span class="nowrap">{}</span>', fmt_time(message.created_at))

    @admin.display(description="dir", ordering="direction")
    def way(self, message: SmsMessage) -> str:
        return message.direction

    @admin.display(description="result")
    def result(self, message: SmsMessage) -> str:
        """An incoming SMS's outcome, an outgoing one's send status."""
        if message.direction == Direction.IN:
            return message.get_outcome_display()
        return message.get_status_display()

    @admin.display(description="number", ordering="number")
    def shown_number(self, message: SmsMessage) -> str:
        return message.number_e164 or message.number

    @admin.display(description="text")
    def text_summary(self, message: SmsMessage) -> str:
        text = message.text if len(message.text) <= TEXT_SHOWN else message.text[:TEXT_SHOWN] + "…"
        # Wide enough to read a reply in a few lines rather than a word per line.
        return format_html('<span style="display:inline-block;min-width:14em">{}</span>', text)

    @admin.display(description="parsed")
    def parsed_pretty(self, message: SmsMessage) -> str:
        if not message.parsed:
            return "–"
        return format_html(
            "<pre>{}</pre>", json.dumps(message.parsed, indent=1, ensure_ascii=False)
        )

    @admin.display(description="in reply to")
    def reply_link(self, message: SmsMessage) -> str:
        if message.reply_to_id is None:
            return "–"
        url = reverse("admin:sms_smsmessage_change", args=[message.reply_to_id])
        return format_html('<a href="{}">{}</a>', url, message.reply_to)

    @admin.display(description="commands")
    def command_links(self, message: SmsMessage) -> str:
        commands = message.commands.order_by("pk")
        if not commands:
            return "–"
        return format_html_join(
            ", ",
            '<a href="{}">{} ({})</a>',
            (
                (reverse("admin:commands_command_change", args=[c.pk]), c.kind, c.status)
                for c in commands
            ),
        )
