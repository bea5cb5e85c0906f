"""Telemetry admin, built to stay fast on tables with millions of fixes."""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.contrib import admin
from django.contrib.admin.options import IncorrectLookupParameters
from django.core.paginator import Paginator
from django.db.models import QuerySet
from django.http import HttpRequest
from django.utils import timezone
from django.utils.functional import cached_property

from telemetry.models import Fix, SensorChannel
from telemetry.services import fixes_delete, sensor_channel_save
from vessels.models import Vessel

# Counting past this is never worth a full scan: the admin shows "10000+" pages' worth.
COUNT_CAP = 10_000
BIGINT_MAX = 2**63 - 1


class CappedCountPaginator(Paginator):
    """Counts at most COUNT_CAP rows (COUNT over a LIMITed subquery), not the whole table."""

    @cached_property
    def count(self) -> int:
        return self.object_list.order_by()[:COUNT_CAP].count()


class VesselFilter(admin.SimpleListFilter):
    """Lists vessels from the (small) vessel table, not DISTINCT over millions of fixes."""

    title = "vessel"
    parameter_name = "vessel"

    def lookups(self, request: HttpRequest, model_admin: Any) -> list[tuple[int, str]]:
        return [(v.pk, v.name) for v in Vessel.objects.order_by("name")]

    def queryset(self, request: HttpRequest, queryset: QuerySet[Fix]) -> QuerySet[Fix]:
        if not self.value():
            return queryset
        # A hand-edited URL must not be a 500: the admin answers IncorrectLookupParameters
        # with its "?e=1" page. Bounded: SQLite cannot even bind an integer past 64 bits.
        try:
            vessel_id = int(self.value())
        except ValueError:
            raise IncorrectLookupParameters(f"vessel={self.value()!r}") from None
        if not 0 < vessel_id <= BIGINT_MAX:
            raise IncorrectLookupParameters(f"vessel={self.value()!r}")
        return queryset.filter(vessel_id=vessel_id)


class RecordedFilter(admin.SimpleListFilter):
    title = "recorded"
    parameter_name = "recorded"
    RANGES = {
        "1h": dt.timedelta(hours=1),
        "24h": dt.timedelta(days=1),
        "7d": dt.timedelta(days=7),
        "30d": dt.timedelta(days=30),
    }

    def lookups(self, request: HttpRequest, model_admin: Any) -> list[tuple[str, str]]:
        return [
            ("1h", "Last hour"),
            ("24h", "Last 24 hours"),
            ("7d", "Last 7 days"),
            ("30d", "Last 30 days"),
        ]

    def queryset(self, request: HttpRequest, queryset: QuerySet[Fix]) -> QuerySet[Fix]:
        span = self.RANGES.get(self.value() or "")
        return queryset.filter(recorded_at__gte=timezone.now() - span) if span else queryset


@admin.register(Fix)
class FixAdmin(admin.ModelAdmin):
    list_display = [
        "recorded_at",
        "vessel",
        "lat",
        "lon",
        "heading_deg",
        "speed_mps",
        "battery_v",
        "readings",
    ]
    list_filter = [VesselFilter, RecordedFilter]
    list_select_related = ["vessel"]
    ordering = ["-recorded_at"]
    paginator = CappedCountPaginator
    show_full_result_count = False
    list_per_page = 100
    readonly_fields = [
        "vessel",
        "recorded_at",
        "received_at",
        "lat",
        "lon",
        "heading_deg",
        "speed_mps",
        "battery_v",
        "readings",
    ]

    # Fixes are the vessel's record of what happened: read-only, never typed in.
    def has_add_permission(self, request: HttpRequest) -> bool:
        return False

    def has_change_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False

    # Deleting goes through the service, which keeps the track overview in step.
    def delete_model(self, request: HttpRequest, obj: Fix) -> None:
        fixes_delete(fixes=Fix.objects.filter(pk=obj.pk))

    def delete_queryset(self, request: HttpRequest, queryset: QuerySet[Fix]) -> None:
        fixes_delete(fixes=queryset)


@admin.register(SensorChannel)
class SensorChannelAdmin(admin.ModelAdmin):
    list_display = ["key", "label", "unit", "minimum", "maximum"]
    search_fields = ["key", "label"]

    def save_model(self, request: HttpRequest, obj: SensorChannel, form: Any, change: bool) -> None:
        sensor_channel_save(channel=obj)
