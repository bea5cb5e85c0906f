"""The SBD log in the admin: read-only (messages are written by the webhook and the sender)."""

from __future__ import annotations

from django.contrib import admin

from audit.admin import LogAdmin
from sbd.models import SbdMessage
from sbd.rockblock import credits


@admin.register(SbdMessage)
class SbdMessageAdmin(LogAdmin):
    list_display = [
        "received_at",
        "direction",
        "vessel",
        "imei",
        "momsn",
        "bytes",
        "credits",
        "status",
        "fixes",
        "command",
        "detail",
    ]
    list_filter = ["direction", "status", "vessel"]
    list_select_related = ["vessel", "command"]
    search_fields = ["imei", "vessel__name", "vessel__slug", "provider_ref"]
    date_hierarchy = "received_at"
    readonly_fields = ["payload_hex", "credits"]
    exclude = ["payload"]

    @admin.display(description="credits")
    def credits(self, message: SbdMessage) -> int:
        return credits(message.bytes)

    @admin.display(description="payload (hex)")
    def payload_hex(self, message: SbdMessage) -> str:
        return bytes(message.payload).hex(" ") or "–"
