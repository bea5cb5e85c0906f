"""The link counts in the admin: read-only (written only by adding, links.sql)."""

from __future__ import annotations

from typing import Any

from django.contrib import admin
from django.http import HttpRequest

from links.models import LinkDay


@admin.register(LinkDay)
class LinkDayAdmin(admin.ModelAdmin):
    list_display = ["day", "vessel", "transport", "messages_in", "messages_out", "bytes_in",
                    "bytes_out", "credits", "fixes_in", "last_contact_at"]  # fmt: skip
    list_filter = ["transport", "vessel"]
    list_select_related = ["vessel"]
    date_hierarchy = "day"

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False
