"""Telemetry admin, built to stay fast on tables with millions of fixes."""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.contrib import admin
from django.contrib.admin.options import IncorrectLookupParameters
from django.contrib.admin.views.main import ChangeList
from django.core.paginator import Paginator
from django.db.models import QuerySet
from django.http import HttpRequest
from django.utils import timezone
from django.utils.functional import cached_property
from django.utils.html import format_html, format_html_join
from django.utils.safestring import SafeString

from telemetry.models import Fix, SensorChannel
from telemetry.services import fixes_delete, sensor_channel_save
from vessels.display import (
    BATTERY,
    fmt_ddm,
    fmt_heading,
    fmt_position,
    fmt_readings,
    fmt_speed,
    fmt_time,
)
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


def channel_labels() -> dict[str, dict[str, Any]]:
    """{key: {label, unit}}: battery, then every SensorChannel (a few dozen rows at most)."""
    labels = {"battery_v": BATTERY}
    labels.update({c.key: {"label": c.label, "unit": c.unit} for c in SensorChannel.objects.all()})
    return labels


def readings_html(fix: Fix, labels: dict[str, dict[str, Any]]) -> SafeString:
    """A fix's battery and readings on one line: ``Mode HOLD · armed · Battery 12.4 V · …``."""
    values = dict(fix.readings or {})
    if fix.battery_v is not None:
        values["battery_v"] = fix.battery_v
    parts = fmt_readings(values, labels)
    if not parts:
        return format_html("{}", "–")
    # One unbreakable piece per reading, the dot kept with the one before: a narrow window
    # wraps between readings, never between a label and its value nor before a dot.
    return format_html_join("\u00a0· ", '<span class="nowrap">{}</span>', ((p,) for p in parts))


class FixChangeList(ChangeList):
    """Reads the channel labels once for the page and hands them to its rows."""

    def get_results(self, request: HttpRequest) -> None:
        super().get_results(request)
        labels = channel_labels()
        for fix in self.result_list:
            fix.channel_labels = labels


@admin.register(Fix)
class FixAdmin(admin.ModelAdmin):
    # Narrow columns, each reading a short unbreakable piece: the list fits a 1400 px window
    # and a row stays one line unless it has many readings.
    list_display = ["time", "vessel", "position", "heading", "speed", "readings_line"]
    list_filter = [VesselFilter, RecordedFilter]
    list_select_related = ["vessel"]
    ordering = ["-recorded_at"]
    paginator = CappedCountPaginator
    show_full_result_count = False
    list_per_page = 100
    fields = [
        "vessel",
        "time",
        "received",
        "position",
        "heading",
        "speed",
        "readings_line",
    ]
    readonly_fields = fields

    class Media:
        css = {"all": ["telemetry/fix_list.css"]}

    def get_changelist(self, request: HttpRequest, **kwargs: Any) -> type[ChangeList]:
        return FixChangeList

    def changelist_view(self, request: HttpRequest, extra_context: Any = None) -> Any:
        # The admin's widest list: without the app navigation on its left (the breadcrumbs
        # lead back) and with its filters above it (fix_list.css), a usual fix's readings stay
        # on one line in a 1400 px window.
        context = {"is_nav_sidebar_enabled": False, **(extra_context or {})}
        return super().changelist_view(request, extra_context=context)

    @admin.display(description="time", ordering="recorded_at")
    def time(self, fix: Fix) -> SafeString:
        return format_html('<span class="nowrap">{}</span>', fmt_time(fix.recorded_at))

    @admin.display(description="received")
    def received(self, fix: Fix) -> str:
        return fmt_time(fix.received_at)

    @admin.display(description="position")
    def position(self, fix: Fix) -> SafeString:
        # Decimal degrees to read and copy; the chart form (degrees, decimal minutes) on hover.
        return format_html(
            '<span class="nowrap" title="{}">{}</span>',
            fmt_ddm(fix.lat, fix.lon),
            fmt_position(fix.lat, fix.lon),
        )

    @admin.display(description="heading")
    def heading(self, fix: Fix) -> str:
        return fmt_heading(fix.heading_deg)

    @admin.display(description="speed")
    def speed(self, fix: Fix) -> SafeString:
        return format_html('<span class="nowrap">{}</span>', fmt_speed(fix.speed_mps))

    @admin.display(description="readings")
    def readings_line(self, fix: Fix) -> SafeString:
        return readings_html(fix, getattr(fix, "channel_labels", None) or channel_labels())

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
