"""Admin for alert rules, alerts (acknowledge) and notification channels (a webhook's secret is
shown once, in a message after it is made); the fences' admin is alerts.fence_admin. Every
write goes through alerts.services."""

from __future__ import annotations

from typing import Any

from django import forms
from django.contrib import admin, messages
from django.db.models import QuerySet
from django.http import HttpRequest
from django.utils import timezone
from django.utils.html import format_html

from alerts import fence_admin  # noqa: F401  (registers the fences' admin)
from alerts.models import Alert, AlertRule, AlertState, ChannelKind, NotificationChannel
from alerts.services.alerts import alert_acknowledge
from alerts.services.channels import notification_channel_delete, notification_channel_update
from alerts.services.notifications import notification_channel_create
from alerts.services.rules import (
    RULE_FIELDS,
    alert_rule_create,
    alert_rule_delete,
    alert_rule_update,
    rule_problems,
)

# The alert states' colours: the fleet map's (fleet/static/fleet/maps.css .alert-*).
STATE_COLOURS = {"open": "#c62828", "acknowledged": "#ef6c00", "resolved": "#757575"}


def state_badge(state: str) -> str:
    return format_html(
        '<b class="alert-state alert-{}" style="color:{}">{}</b>',
        state, STATE_COLOURS.get(state, "#000"), state,
    )  # fmt: skip


class AlertRuleForm(forms.ModelForm):
    class Meta:
        model = AlertRule
        fields = [*RULE_FIELDS, "channels"]

    def _post_clean(self) -> None:
        super()._post_clean()
        # The service's checks by kind, on the form's fields: the page marks each one.
        for field, problems in rule_problems(self.instance).items():
            for problem in problems:
                self.add_error(field if field in self.fields else None, problem)


@admin.register(AlertRule)
class AlertRuleAdmin(admin.ModelAdmin):
    form = AlertRuleForm
    list_display = ["name", "kind", "applies_to", "limit", "active", "updated_at"]
    list_filter = ["kind", "active", "vessel_kind"]
    list_select_related = ["vessel", "fence"]
    search_fields = ["name", "reading"]
    filter_horizontal = ["channels"]
    fieldsets = [
        (None, {"fields": ["name", "kind", "active"]}),
        ("Which vessels", {"fields": ["vessel", "vessel_kind"]}),
        (
            "Limit",
            {
                "fields": ["threshold", "reading", "minimum", "maximum", "fence"],
                "description": "Overdue: threshold in telemetry periods. Battery: threshold "
                "in volts. Endurance: threshold in hours. Reading: the reading's key with a "
                "minimum and/or maximum (empty: its sensor channel's). Fence: the fence.",
            },
        ),
        ("Who is told", {"fields": ["channels"]}),
    ]

    @admin.display(description="applies to")
    def applies_to(self, rule: AlertRule) -> str:
        if rule.vessel_id:
            return str(rule.vessel)
        return (
            f"every {rule.get_vessel_kind_display()} vessel" if rule.vessel_kind else "every vessel"
        )

    @admin.display(description="limit")
    def limit(self, rule: AlertRule) -> str:
        if rule.kind == "reading":
            low = "" if rule.minimum is None else f"{rule.minimum:g} ≤ "
            high = "" if rule.maximum is None else f" ≤ {rule.maximum:g}"
            return (
                f"{low}{rule.reading}{high}" if low or high else f"{rule.reading} (channel limits)"
            )
        if rule.kind == "fence":
            return str(rule.fence)
        if rule.kind == "budget":
            what = rule.reading or "every link"
            default = f", {rule.threshold:g} without one" if rule.threshold is not None else ""
            return f"{what}: the vessel's budget{default}"
        units = {"overdue": "periods", "battery": "V", "endurance": "h"}
        return f"{rule.threshold:g} {units[rule.kind]}" if rule.threshold is not None else ""

    def save_model(self, request: HttpRequest, obj: AlertRule, form: Any, change: bool) -> None:
        who = {
            "by": request.user.get_username(),
            "via": "admin",
            "ip": request.META.get("REMOTE_ADDR"),
        }
        fields = {
            name: form.cleaned_data[name] for name in RULE_FIELDS if name in form.cleaned_data
        }
        channels = form.cleaned_data.get("channels", [])
        if change:
            # As saved, not as the form left it: the audit entry says what changed.
            saved = AlertRule.objects.get(pk=obj.pk)
            saved = alert_rule_update(rule=saved, fields=fields, channels=channels, **who)
        else:
            saved = alert_rule_create(fields=fields, channels=channels, **who)
        obj.pk = saved.pk

    def save_related(self, request: HttpRequest, form: Any, formsets: Any, change: bool) -> None:
        pass  # the service set the channels

    def delete_model(self, request: HttpRequest, obj: AlertRule) -> None:
        alert_rule_delete(rule=obj, by=request.user.get_username(), via="admin")

    def delete_queryset(self, request: HttpRequest, queryset: QuerySet[AlertRule]) -> None:
        for rule in queryset:
            self.delete_model(request, rule)


class ActiveFilter(admin.SimpleListFilter):
    title = "state"
    parameter_name = "active"

    def lookups(self, request: HttpRequest, model_admin: Any) -> list[tuple[str, str]]:
        return [("yes", "Open or acknowledged"), *AlertState.choices]

    def queryset(self, request: HttpRequest, queryset: QuerySet[Alert]) -> QuerySet[Alert]:
        value = self.value()
        if value == "yes":
            return queryset.exclude(state=AlertState.RESOLVED)
        return queryset.filter(state=value) if value else queryset


@admin.register(Alert)
class AlertAdmin(admin.ModelAdmin):
    list_display = [
        "opened_at", "vessel", "rule", "kind", "state_shown", "detail", "acknowledged_by",
        "resolved_at",
    ]  # fmt: skip
    list_filter = [ActiveFilter, "kind", "vessel"]
    list_select_related = ["vessel", "rule"]
    date_hierarchy = "opened_at"
    actions = ["acknowledge"]
    show_full_result_count = False
    readonly_fields = [
        "rule", "vessel", "kind", "subject", "state_shown", "opened_at", "value", "detail",
        "acknowledged_at", "acknowledged_by", "resolved_at", "fix",
    ]  # fmt: skip
    fields = readonly_fields

    @admin.display(description="state", ordering="state")
    def state_shown(self, alert: Alert) -> str:
        return state_badge(alert.state)

    def has_add_permission(self, request: HttpRequest) -> bool:
        return False  # the evaluator opens alerts

    def has_delete_permission(self, request: HttpRequest, obj: Any = None) -> bool:
        return False  # an alert is a record; it resolves itself

    def has_acknowledge_permission(self, request: HttpRequest) -> bool:
        return request.user.has_perm("alerts.change_alert")

    @admin.action(description="Acknowledge selected alerts", permissions=["acknowledge"])
    def acknowledge(self, request: HttpRequest, queryset: QuerySet[Alert]) -> None:
        done = 0
        for alert in queryset.filter(state=AlertState.OPEN):
            done += alert_acknowledge(
                alert=alert, by=request.user.get_username(), now=timezone.now()
            )
        left = queryset.count() - done
        messages.success(request, f"Acknowledged {done} alert(s).")
        if left:
            messages.info(request, f"{left} were acknowledged or resolved already.")


class ChannelForm(forms.ModelForm):
    new_secret = forms.CharField(
        label="secret",
        required=False,
        min_length=16,
        max_length=128,
        help_text="A webhook's signing key; empty: one is generated and shown once, after saving.",
    )

    class Meta:
        model = NotificationChannel
        fields = ["name", "kind", "target", "active"]

    def clean(self) -> dict[str, Any]:
        data = super().clean()
        if data.get("new_secret") and data.get("kind") != ChannelKind.WEBHOOK:
            self.add_error("new_secret", "Only a webhook has a secret.")
        return data


@admin.register(NotificationChannel)
class NotificationChannelAdmin(admin.ModelAdmin):
    form = ChannelForm
    list_display = ["name", "kind", "target", "active", "signed", "created_at"]
    list_filter = ["kind", "active"]
    search_fields = ["name", "target"]

    @admin.display(description="signed", boolean=True)
    def signed(self, channel: NotificationChannel) -> bool:
        return bool(channel.secret)

    def get_fields(self, request: HttpRequest, obj: NotificationChannel | None = None) -> Any:
        # The kind and secret are set once: a new secret is a new channel.
        return (
            ["name", "kind", "target", "new_secret"]
            if obj is None
            else ["name", "kind", "target", "active"]
        )

    def get_readonly_fields(self, request: HttpRequest, obj: Any = None) -> Any:
        return ["kind"] if obj else []

    def save_model(
        self, request: HttpRequest, obj: NotificationChannel, form: Any, change: bool
    ) -> None:
        by = request.user.get_username()
        data = form.cleaned_data
        if change:
            fields = {name: data[name] for name in ("name", "target", "active") if name in data}
            saved = NotificationChannel.objects.get(pk=obj.pk)  # as saved (the audit's "from")
            notification_channel_update(channel=saved, fields=fields, by=by)
            return
        channel, secret = notification_channel_create(
            name=data["name"], kind=data["kind"], target=data["target"],
            secret=data.get("new_secret") or None, by=by,
        )  # fmt: skip
        obj.pk = channel.pk
        if secret:
            messages.warning(
                request,
                format_html(
                    "The secret of {}: <code class=\"channel-secret\">{}</code> — copy it now: "
                    "it is not shown again. The receiver checks X-Shoreside-Signature with it.",
                    channel.name, secret,
                ),
            )  # fmt: skip

    def delete_model(self, request: HttpRequest, obj: NotificationChannel) -> None:
        notification_channel_delete(channel=obj, by=request.user.get_username())

    def delete_queryset(
        self, request: HttpRequest, queryset: QuerySet[NotificationChannel]
    ) -> None:
        for channel in queryset:
            self.delete_model(request, channel)
