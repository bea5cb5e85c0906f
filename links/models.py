"""What each link (HTTP, SMS, Iridium SBD) carried and cost, per vessel and UTC day."""

from __future__ import annotations

from django.db import models

from vessels.models import Vessel


class Transport(models.TextChoices):
    HTTP = "http", "HTTP"
    SMS = "sms", "SMS"
    SBD = "sbd", "Iridium SBD"


class LinkDay(models.Model):
    """One vessel's traffic on one transport on one UTC day. Written only by adding to it
    (links.sql.link_day_add: an atomic upsert), never read-modify-written."""

    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="link_days")
    day = models.DateField(help_text="UTC date.")
    transport = models.CharField(max_length=4, choices=Transport.choices)
    messages_in = models.PositiveIntegerField(default=0)
    messages_out = models.PositiveIntegerField(default=0)
    bytes_in = models.PositiveBigIntegerField(default=0)
    bytes_out = models.PositiveBigIntegerField(default=0)
    # SBD: RockBLOCK credits (50 bytes each, one at least); SMS: segments; HTTP: none.
    credits = models.PositiveIntegerField(default=0)
    fixes_in = models.PositiveIntegerField(default=0)
    # The newest time the vessel was heard on this transport that day (outbound traffic
    # is not contact).
    last_contact_at = models.DateTimeField(null=True, blank=True)

    class Meta:
        ordering = ["-day", "vessel", "transport"]
        verbose_name = "link day"
        constraints = [
            models.UniqueConstraint(
                fields=["vessel", "day", "transport"], name="linkday_one_per_day"
            ),
        ]

    def __str__(self) -> str:
        return f"{self.vessel} {self.transport} {self.day}"
