"""Authorised phone numbers and the log of every SMS in and out (docs/sms.md)."""

from __future__ import annotations

from django.db import models
from django.db.models import Q

from commands.models import Command
from vessels.models import Vessel

E164_MAX = 16  # "+" and at most 15 digits (ITU-T E.164)
RAW_NUMBER_MAX = 40  # what a modem reports as the sender: a number, or an alphanumeric name
ORIGIN_ID_MAX = 64


class Role(models.TextChoices):
    QUERY = "query", "Query (queries, #STATUS, #HELP)"
    CONTROL = "control", "Control (also commands)"


class AuthorisedNumber(models.Model):
    """A phone allowed to text the vessels it lists; anyone else is logged and not answered."""

    number = models.CharField(
        max_length=E164_MAX,
        unique=True,
        help_text="E.164 (+61412345678); a national number is read in SMS_DEFAULT_REGION.",
    )
    name = models.CharField(max_length=100, help_text="Who holds the phone.")
    vessels = models.ManyToManyField(Vessel, related_name="authorised_numbers", blank=True)
    role = models.CharField(max_length=10, choices=Role.choices, default=Role.QUERY)
    active = models.BooleanField(default=True)
    expires_at = models.DateTimeField(null=True, blank=True, help_text="Empty: never.")
    receives_positions = models.BooleanField(
        "receives positions",
        default=False,
        help_text="The Wave Glider bridge texts this number the glider's position on its "
        "schedule (WG_POSITION_SMS_PERIOD_S), while the number is active.",
    )
    notes = models.TextField(blank=True)
    created_at = models.DateTimeField(auto_now_add=True)
    updated_at = models.DateTimeField(auto_now=True)

    class Meta:
        ordering = ["name", "number"]
        verbose_name = "authorised number"

    def __str__(self) -> str:
        return f"{self.name} ({self.number})"


class Direction(models.TextChoices):
    IN = "in", "in"
    OUT = "out", "out"


class Outcome(models.TextChoices):
    """What became of an incoming SMS."""

    ACCEPTED = "accepted", "accepted"  # every part understood and carried out or answered
    ERROR = "error", "answered with errors"  # at least one part refused (ERR in the reply)
    REFUSED = "refused", "refused"  # a known number, inactive, expired, other vessel or role
    STRANGER = "stranger", "stranger"  # not an authorised number
    RATE_LIMITED = "rate_limited", "rate limited"


class SendStatus(models.TextChoices):
    """Where an outgoing SMS stands; the modem loop sends the pending ones."""

    # A reply held back for the commands' outcome until ``due_at`` (sms_replies_due).
    WAITING = "waiting", "waiting for the outcome"
    PENDING = "pending", "pending"
    SENT = "sent", "sent"
    FAILED = "failed", "failed"
    NOT_SENT = "not_sent", "not sent"  # shown by sms_inject, never to be sent


class SmsMessage(models.Model):
    direction = models.CharField(max_length=3, choices=Direction.choices)
    vessel = models.ForeignKey(Vessel, on_delete=models.CASCADE, related_name="sms_messages")
    # Blank: a modem may report no sender at all; that SMS is logged as a stranger's.
    number = models.CharField(
        max_length=RAW_NUMBER_MAX,
        blank=True,
        help_text="As the modem reported it (sender or recipient).",
    )
    number_e164 = models.CharField(
        "E.164 number",
        max_length=E164_MAX,
        blank=True,
        help_text="Normalised; empty when not a phone number.",
    )
    authorised_number = models.ForeignKey(
        AuthorisedNumber,
        on_delete=models.SET_NULL,
        null=True,
        blank=True,
        related_name="messages",
    )
    text = models.TextField(blank=True)
    authorised = models.BooleanField(default=False)
    outcome = models.CharField(max_length=20, choices=Outcome.choices, blank=True)
    detail = models.CharField(max_length=200, blank=True, help_text="Why it was refused.")
    parsed = models.JSONField(default=list, blank=True, help_text="Each part as understood.")
    reply_to = models.ForeignKey(
        "self", on_delete=models.CASCADE, null=True, blank=True, related_name="replies"
    )
    commands = models.ManyToManyField(Command, related_name="sms_messages", blank=True)
    modem_timestamp = models.DateTimeField(
        null=True, blank=True, help_text="The service centre time stamp the modem reported."
    )
    # Incoming: SHA-256 of (vessel, number, text, modem timestamp): the same delivery twice is
    # handled once (a modem re-reads its store after a restart). Empty without a modem time
    # stamp. Outgoing: "rate:<number>:<until>" on a rate limit notice, sent once per block.
    delivery_key = models.CharField(max_length=64, null=True, blank=True, unique=True)
    received_at = models.DateTimeField(null=True, blank=True)
    created_at = models.DateTimeField(auto_now_add=True)
    status = models.CharField(max_length=10, choices=SendStatus.choices, blank=True)
    status_detail = models.CharField(max_length=200, blank=True)
    reference = models.CharField(
        max_length=20, blank=True, help_text="The modem's +CMGS reference."
    )
    sent_at = models.DateTimeField(null=True, blank=True)
    # A waiting reply goes out at this time whatever its commands did; empty: when they end.
    due_at = models.DateTimeField(null=True, blank=True)
    # On the shore: the glider's own id for an entry of its SMS log uploaded through the boat
    # API (POST /api/v1/boat/sms/), unique per vessel so that a re-sent upload is a no-op.
    origin_id = models.CharField(
        max_length=ORIGIN_ID_MAX,
        null=True,
        blank=True,
        help_text="Uploaded from the vessel's own log: its id there.",
    )

    class Meta:
        ordering = ["-created_at", "-pk"]
        verbose_name = "SMS message"
        indexes = [
            # The admin's log, newest first, all vessels or one.
            models.Index(fields=["-created_at"], name="sms_created_desc"),
            models.Index(fields=["vessel", "-created_at"], name="sms_vessel_created"),
            # Rate limiting (sms.services.incoming._rate_limited_until): one number's incoming
            # messages in a time window that count, the ones it held back left out.
            models.Index(
                fields=["number_e164", "received_at"],
                condition=Q(direction="in") & ~Q(outcome="rate_limited"),
                name="sms_in_rate_count",
            ),
            # The modem loop's queue (sms_outgoing_pending).
            models.Index(
                fields=["vessel", "created_at"],
                condition=Q(direction="out", status="pending"),
                name="sms_out_pending",
            ),
        ]
        constraints = [
            models.CheckConstraint(
                condition=Q(direction="in", status="") | Q(direction="out") & ~Q(status=""),
                name="sms_status_for_outgoing_only",
            ),
            models.UniqueConstraint(
                fields=["vessel", "origin_id"],
                condition=Q(origin_id__isnull=False),
                name="sms_unique_origin_per_vessel",
            ),
        ]

    def __str__(self) -> str:
        arrow = "←" if self.direction == Direction.IN else "→"
        return f"{arrow} {self.number_e164 or self.number}: {self.text[:40]}"
