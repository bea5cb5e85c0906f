"""Alert rules, the alerts they open, and the channels that tell people (docs/alerts.md)."""

from __future__ import annotations

from django.db import models
from django.db.models import Q

from telemetry.models import Fix
from vessels.models import Fence, Vessel, VesselKind


class RuleKind(models.TextChoices):
    OVERDUE = "overdue", "Overdue (silent for N telemetry periods)"
    BATTERY = "battery", "Battery below a voltage"
    READING = "reading", "Reading outside min/max"
    ENDURANCE = "endurance", "Battery endurance below N hours"
    FENCE = "fence", "Outside an inclusion fence or inside an exclusion fence"
    COMMAND = "command", "Command failed or expired"
    BUDGET = "budget", "Link budget crossed (SBD credits, SMS, HTTP kB a day)"


class ChannelKind(models.TextChoices):
    EMAIL = "email", "E-mail"
    SMS = "sms", "SMS"
    WEBHOOK = "webhook", "Webhook"


class NotificationChannel(models.Model):
    name = models.CharField(max_length=100)
    kind = models.CharField(max_length=10, choices=ChannelKind.choices)
    target = models.CharField(max_length=500, help_text="E-mail address, phone number or URL.")
    # A webhook's HMAC key: shown once when made, never again (alerts.services).
    secret = models.CharField(max_length=128, blank=True, editable=False)
    active = models.BooleanField(default=True)
    created_at = models.DateTimeField(auto_now_add=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return f"{self.name} ({self.kind})"

    def clean(self) -> None:
        """The target checked and normalised for the kind (E.164 for a number): one rule for
        the admin, the API and the service (alerts.notify.targets)."""
        from alerts.notify.targets import clean_target  # models load before the sms services

        if self.kind in ChannelKind.values:
            self.target = clean_target(self.kind, self.target)


class AlertRule(models.Model):
    name = models.CharField(max_length=100)
    vessel = models.ForeignKey(
        Vessel,
        on_delete=models.CASCADE,
        null=True,
        blank=True,
        related_name="alert_rules",
        help_text="One vessel; empty: every vessel (of the kind below, if one is chosen).",
    )
    vessel_kind = models.CharField(
        max_length=20, choices=VesselKind.choices, blank=True, help_text="Empty: every kind."
    )
    kind = models.CharField(max_length=10, choices=RuleKind.choices)
    threshold = models.FloatField(
        null=True,
        blank=True,
        help_text="Periods for overdue, volts for battery, hours for endurance; for budget, "
        "the daily budget of a vessel that has none of its own.",
    )
    reading = models.CharField(
        max_length=50,
        blank=True,
        help_text="Reading key, for reading; for budget, one transport (sbd, sms, http) or "
        "empty for all three.",
    )
    minimum = models.FloatField(null=True, blank=True, help_text="For reading.")
    maximum = models.FloatField(null=True, blank=True, help_text="For reading.")
    fence = models.ForeignKey(
        Fence, on_delete=models.CASCADE, null=True, blank=True, related_name="rules"
    )
    channels = models.ManyToManyField(NotificationChannel, blank=True, related_name="rules")
    active = models.BooleanField(default=True)
    created_at = models.DateTimeField(auto_now_add=True)
    updated_at = models.DateTimeField(auto_now=True)

    class Meta:
        ordering = ["name"]

    def __str__(self) -> str:
        return self.name


class AlertState(models.TextChoices):
    OPEN = "open", "Open"
    ACKNOWLEDGED = "acknowledged", "Acknowledged"
    RESOLVED = "resolved", "Resolved"


ACTIVE_STATES = (AlertState.OPEN, AlertState.ACKNOWLEDGED)


class Alert(models.Model):
    """One episode of a rule's condition on one vessel: opened once, resolved when it clears."""

    rule = models.ForeignKey(AlertRule, on_delete=models.CASCADE, related_name="alerts")
    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="alerts")
    kind = models.CharField(max_length=10, choices=RuleKind.choices)
    # What the episode is about beyond rule and vessel: a command rule's command uid; "" else.
    subject = models.CharField(max_length=64, blank=True)
    state = models.CharField(max_length=12, choices=AlertState.choices, default=AlertState.OPEN)
    opened_at = models.DateTimeField()
    acknowledged_at = models.DateTimeField(null=True, blank=True)
    acknowledged_by = models.CharField(max_length=150, blank=True)
    resolved_at = models.DateTimeField(null=True, blank=True)
    detail = models.TextField(blank=True)
    value = models.FloatField(null=True, blank=True, help_text="The value that opened it.")
    # The fix that opened it: retention keeps it (telemetry's thinning).
    fix = models.ForeignKey(Fix, on_delete=models.SET_NULL, null=True, blank=True, related_name="+")

    class Meta:
        ordering = ["-opened_at", "-pk"]
        constraints = [
            # One live episode per rule, vessel and subject: two evaluators racing open one.
            models.UniqueConstraint(
                fields=["rule", "vessel", "subject"],
                condition=Q(state__in=[s.value for s in ACTIVE_STATES]),
                name="alert_one_active_episode",
            ),
        ]
        indexes = [
            # Open alerts on the map, the vessel list and the vessel page.
            models.Index(
                fields=["vessel"],
                condition=Q(state__in=[s.value for s in ACTIVE_STATES]),
                name="alert_active_by_vessel",
            ),
        ]

    def __str__(self) -> str:
        return f"{self.rule} on {self.vessel} ({self.state})"


class NotificationState(models.TextChoices):
    PENDING = "pending", "Pending"
    SENDING = "sending", "Sending"
    SENT = "sent", "Sent"
    FAILED = "failed", "Failed"


class Notification(models.Model):
    """One message owed to one channel about one alert event; claimed, sent, retried."""

    alert = models.ForeignKey(Alert, on_delete=models.CASCADE, related_name="notifications")
    channel = models.ForeignKey(
        NotificationChannel, on_delete=models.CASCADE, related_name="notifications"
    )
    # alert.opened, alert.acknowledged or alert.resolved.
    event = models.CharField(max_length=30)
    state = models.CharField(
        max_length=10, choices=NotificationState.choices, default=NotificationState.PENDING
    )
    created_at = models.DateTimeField()
    due_at = models.DateTimeField()
    attempts = models.PositiveIntegerField(default=0)
    claimed_by = models.CharField(max_length=64, blank=True)
    claimed_at = models.DateTimeField(null=True, blank=True)
    sent_at = models.DateTimeField(null=True, blank=True)
    last_error = models.TextField(blank=True)
    # Sent as part of another notification's summary (a flood of alerts in one message).
    summarised_in = models.ForeignKey(
        "self", on_delete=models.SET_NULL, null=True, blank=True, related_name="+"
    )

    class Meta:
        ordering = ["created_at", "pk"]
        indexes = [
            # The sender's claim scan (alerts.services.notifications).
            models.Index(
                fields=["due_at"],
                condition=Q(state__in=["pending", "sending"]),
                name="notification_due",
            ),
        ]

    def __str__(self) -> str:
        return f"{self.event} → {self.channel} ({self.state})"
