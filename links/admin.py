"""The link counts in the admin: read-only (written only by adding, links.sql)."""

from __future__ import annotations

from django.contrib import admin

from audit.admin import LogAdmin
from links.models import LinkDay


@admin.register(LinkDay)
class LinkDayAdmin(LogAdmin):
    list_display = ["day", "vessel", "transport", "messages_in", "messages_out", "bytes_in",
                    "bytes_out", "credits", "fixes_in", "last_contact_at"]  # fmt: skip
    list_filter = ["transport", "vessel"]
    list_select_related = ["vessel"]
    date_hierarchy = "day"
