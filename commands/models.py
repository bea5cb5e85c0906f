from __future__ import annotations

import uuid

from django.db import models
from django.db.models import Q

from commands.catalog import KINDS
from commands.lifecycle import OPEN, Status
from vessels.models import Vessel


class Source(models.TextChoices):
    """Where a command came from: the admin's form, the operator API (a script, or the fleet
    map's buttons), an SMS, or the vessel itself (reported up by it)."""

    ADMIN = "admin", "Admin"
    MAP = "map", "Map"
    API = "api", "API"
    SMS = "sms", "SMS"
    VESSEL = "vessel", "Vessel"


class Relay(models.TextChoices):
    SMS = "sms", "SMS"
    SBD = "sbd", "Iridium SBD"
    # No link could carry it (no form for it there, no number, nothing configured).
    NONE = "none", "none possible"


class Command(models.Model):
    uid = models.UUIDField(default=uuid.uuid4, unique=True, editable=False)
    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="commands")
    kind = models.CharField(max_length=20, choices=[(k.name, k.label) for k in KINDS.values()])
    params = models.JSONField(default=dict, blank=True)
    status = models.CharField(
        max_length=20, choices=[(s.value, s.value) for s in Status], default=Status.QUEUED
    )
    source = models.CharField(max_length=10, choices=Source.choices, default=Source.ADMIN)
    created_by = models.CharField(max_length=150, blank=True)
    created_at = models.DateTimeField(auto_now_add=True)
    expires_at = models.DateTimeField(null=True, blank=True)
    sent_at = models.DateTimeField(null=True, blank=True)
    acknowledged_at = models.DateTimeField(null=True, blank=True)
    finished_at = models.DateTimeField(null=True, blank=True)
    result_detail = models.TextField(blank=True)
    # Created on the vessel itself (a glider's SMS or admin) and reported up by it: the shore
    # only mirrors it, so never offers, supersedes or expires it (commands.services).
    reported = models.BooleanField(default=False)
    # Urgent: also sent at once by the vessel's other links (SMS, Iridium SBD), whatever its
    # HTTP link is doing (links.routing); otherwise those carry it only once it is silent.
    urgent = models.BooleanField(
        default=False,
        help_text="Also send it at once by SMS or Iridium SBD, if the vessel has one, "
        "not only when its HTTP link has gone silent.",
    )
    # How the shore relayed it beside HTTP (links.routing, fleet.routing): once at most.
    relay = models.CharField(max_length=4, choices=Relay.choices, blank=True)
    relayed_at = models.DateTimeField(null=True, blank=True)

    class Meta:
        ordering = ["-created_at"]
        indexes = [
            # The boat poll (commands.selectors.open_commands) and supersede/expire scans.
            models.Index(
                fields=["vessel", "created_at"],
                condition=Q(status__in=[s.value for s in OPEN]),
                name="command_open_by_vessel",
            ),
            # The alerts loop's command rules read the commands that ended since its last pass,
            # every few seconds (alerts.evaluator.ended_commands): without it, the whole table.
            models.Index(
                fields=["finished_at"],
                condition=Q(finished_at__isnull=False),
                name="command_finished_at",
            ),
        ]

    def __str__(self) -> str:
        # The vessel's name, not its database id: this is the admin page's title.
        return f"{self.kind} → {self.vessel.name} ({self.status})"


class CommandEvent(models.Model):
    """One status transition of a command: when, from what, to what, and why."""

    command = models.ForeignKey(Command, on_delete=models.CASCADE, related_name="events")
    at = models.DateTimeField()
    from_status = models.CharField(max_length=20, blank=True)
    to_status = models.CharField(max_length=20)
    actor = models.CharField(max_length=150, blank=True)
    detail = models.TextField(blank=True)
    # Machine state a transport records beside ``detail`` (which stays for people): the Wave
    # Glider bridge (sms.bridge.commands) writes these and its replies (sms.services) read them,
    # so nothing is ever parsed back out of the prose. Empty on everyone else's events.
    cc_code = models.PositiveIntegerField(
        null=True, blank=True, help_text="The C&C's answer: 0 for ACK, else the NAK's code."
    )
    cc_reason = models.TextField(
        blank=True,
        help_text="Why the C&C path failed it, as an SMS reply says it: the NAK code's meaning "
        "or the inner command table's refusal.",
    )
    tid = models.PositiveIntegerField(
        null=True, blank=True, help_text="The tid of the Level 2 request that took the command."
    )
    src_task = models.PositiveSmallIntegerField(
        null=True, blank=True, help_text="That request's source task id."
    )
    src_board = models.PositiveSmallIntegerField(
        null=True, blank=True, help_text="That request's source board id."
    )

    class Meta:
        ordering = ["at", "pk"]

    def __str__(self) -> str:
        return f"{self.from_status or '∅'} → {self.to_status}"
