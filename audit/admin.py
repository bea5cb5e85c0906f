"""The audit log in the admin: read-only, filterable, and quick however long it grows."""

from __future__ import annotations

import json
from typing import Any

from django.contrib import admin
from django.core.paginator import Paginator
from django.db.models import QuerySet
from django.http import HttpRequest
from django.utils.functional import cached_property
from django.utils.html import format_html
from django.utils.safestring import SafeString

from audit.models import AuditEntry

# Counting past this is never worth a full scan (the Fix and SMS lists' rule, telemetry.admin;
# audit sits below telemetry and cannot import it): the list shows "10000+" entries' worth.
COUNT_CAP = 10_000


class CappedCountPaginator(Paginator):
    """Counts at most COUNT_CAP rows (COUNT over a LIMITed subquery), not the whole table."""

    @cached_property
    def count(self) -> int:
        return self.object_list.order_by()[:COUNT_CAP].count()


class DistinctValueFilter(admin.SimpleListFilter):
    """The values a column holds (its index read, DISTINCT), never the empty one: a vessel
    deleted long ago still has its slug here, which is what a log is for."""

    field = ""

    def lookups(self, request: HttpRequest, model_admin: Any) -> list[tuple[str, str]]:
        values = (
            AuditEntry.objects.exclude(**{self.field: ""})
            .order_by(self.field)
            .values_list(self.field, flat=True)
            .distinct()
        )
        return [(value, value) for value in values]

    def queryset(self, request: HttpRequest, queryset: QuerySet[AuditEntry]) -> QuerySet:
        value = self.value()
        return queryset.filter(**{self.field: value}) if value else queryset


class ActionFilter(DistinctValueFilter):
    title = "action"
    parameter_name = field = "action"


class VesselFilter(DistinctValueFilter):
    title = "vessel"
    parameter_name = field = "vessel"


class ViaFilter(DistinctValueFilter):
    title = "way in"
    parameter_name = field = "via"


class LogAdmin(admin.ModelAdmin):
    """A log in the admin (the audit log, the SMS log, the SBD log, link counts): written by
    the services that did the work; nobody adds, edits or removes an entry here."""

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False


@admin.register(AuditEntry)
class AuditEntryAdmin(LogAdmin):
    list_display = ["at", "who", "action", "subject", "vessel", "via", "ip"]
    list_filter = [ActionFilter, "actor_kind", ViaFilter, VesselFilter]
    date_hierarchy = "at"
    # "ip" matches part of an address (PostgreSQL compares its text: HOST(ip)).
    search_fields = ["actor", "subject", "subject_id", "ip"]
    ordering = ["-at", "-pk"]
    paginator = CappedCountPaginator
    show_full_result_count = False
    list_per_page = 100
    fields = [
        "at",
        "actor",
        "actor_kind",
        "via",
        "ip",
        "action",
        "subject_type",
        "subject_id",
        "subject",
        "vessel",
        "detail_shown",
    ]
    readonly_fields = fields

    @admin.display(description="who", ordering="actor")
    def who(self, entry: AuditEntry) -> str:
        kind = "" if entry.actor_kind == "operator" else f" ({entry.get_actor_kind_display()})"
        return f"{entry.actor or '–'}{kind}"

    @admin.display(description="detail")
    def detail_shown(self, entry: AuditEntry) -> SafeString:
        text = json.dumps(entry.detail, indent=2, ensure_ascii=False, sort_keys=True)
        return format_html('<pre style="margin:0">{}</pre>', text)
