"""Every Iridium SBD message in and out, as the provider carried it (docs: doc-sbdhook)."""

from __future__ import annotations

from django.db import models
from django.db.models import Q

from commands.models import Command
from vessels.models import Vessel


class Direction(models.TextChoices):
    IN = "in", "in (mobile-originated)"
    OUT = "out", "out (mobile-terminated)"


class Status(models.TextChoices):
    # In: what became of the payload; the Iridium position is kept in all three cases but
    # "decoded" (then the payload's own fixes are the position).
    DECODED = "decoded", "decoded"
    POSITION_ONLY = "position_only", "no fix in the payload: Iridium position kept"
    UNDECODABLE = "undecodable", "payload refused: Iridium position kept"
    # Out: the send queue.
    QUEUED = "queued", "queued"
    SENT = "sent", "sent"
    FAILED = "failed", "failed"


class SbdMessage(models.Model):
    direction = models.CharField(max_length=3, choices=Direction.choices)
    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="sbd_messages")
    imei = models.CharField("IMEI", max_length=15)
    # The modem's message sequence numbers: mobile-originated (in) and, when the provider
    # says, the provider's id of a mobile-terminated one (out).
    momsn = models.PositiveIntegerField("MOMSN", null=True, blank=True)
    provider_ref = models.CharField(max_length=40, blank=True)
    received_at = models.DateTimeField(help_text="In: when it arrived; out: when queued.")
    transmit_time = models.DateTimeField(null=True, blank=True)
    iridium_lat = models.FloatField("Iridium latitude", null=True, blank=True)
    iridium_lon = models.FloatField("Iridium longitude", null=True, blank=True)
    iridium_cep_km = models.FloatField("Iridium CEP (km)", null=True, blank=True)
    payload = models.BinaryField(blank=True, default=b"")
    bytes = models.PositiveIntegerField(default=0, help_text="Payload length: what is paid.")
    status = models.CharField(max_length=15, choices=Status.choices)
    detail = models.CharField(max_length=200, blank=True)
    fixes = models.PositiveIntegerField(default=0, help_text="Fixes stored from it (in).")
    command = models.ForeignKey(
        Command, on_delete=models.SET_NULL, null=True, blank=True, related_name="sbd_messages"
    )
    attempts = models.PositiveSmallIntegerField(default=0)
    sent_at = models.DateTimeField(null=True, blank=True)

    class Meta:
        ordering = ["-received_at", "-pk"]
        verbose_name = "SBD message"
        constraints = [
            # The provider retries a delivery it is not sure of: the same message counts once.
            # The MOMSN is 16 bits and wraps, so the transmit time is part of what names it.
            models.UniqueConstraint(
                fields=["imei", "momsn", "transmit_time"],
                condition=Q(direction="in"),
                name="sbd_in_once",
            ),
        ]
        indexes = [
            models.Index(fields=["vessel", "-received_at"], name="sbd_vessel_received"),
            models.Index(
                fields=["received_at"], condition=Q(status="queued"), name="sbd_out_queue"
            ),
        ]

    def __str__(self) -> str:
        what = f"MOMSN {self.momsn}" if self.direction == Direction.IN else "MT"
        return f"{what} {self.direction} {self.vessel} ({self.bytes} bytes)"
