"""Who did what, from where: one row per action an operator, a phone number, a vessel or the
site itself took. Written by the services that do the work (audit.services.audit_record).

No foreign keys on purpose: an entry outlives its subject and its actor (a deleted vessel,
a revoked token, a removed operator) and still says what happened to whom."""

from __future__ import annotations

from django.db import models


class ActorKind(models.TextChoices):
    OPERATOR = "operator", "Operator"
    PHONE = "phone", "Phone number"
    VESSEL = "vessel", "Vessel"
    SYSTEM = "system", "Shoreside"


class AuditEntry(models.Model):
    at = models.DateTimeField(db_index=True)
    actor = models.CharField(
        max_length=150, blank=True, help_text="Username, phone number or vessel slug."
    )
    actor_kind = models.CharField(
        max_length=10, choices=ActorKind.choices, default=ActorKind.OPERATOR
    )
    # admin, api, map, sms, cli, alerts…: the way in, as a command's source names it.
    via = models.CharField(max_length=20, blank=True)
    ip = models.GenericIPAddressField(null=True, blank=True)
    # Dotted, past tense: "command.queued", "key.revoked", "alert.acknowledged", "login.failed".
    action = models.CharField(max_length=50, db_index=True)
    subject_type = models.CharField(max_length=50, blank=True, help_text="e.g. command, fence.")
    subject_id = models.CharField(max_length=64, blank=True)
    subject = models.CharField(max_length=200, blank=True, help_text="What it was, in words.")
    vessel = models.CharField(max_length=50, blank=True, db_index=True, help_text="Vessel slug.")
    detail = models.JSONField(default=dict, blank=True)

    class Meta:
        ordering = ["-at", "-pk"]
        verbose_name = "audit entry"
        verbose_name_plural = "audit log"

    def __str__(self) -> str:
        return f"{self.at:%Y-%m-%d %H:%M:%S} {self.actor or '-'} {self.action}"
