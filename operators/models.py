"""Operators' personal API tokens (django-rest-knox), stored as a hash only."""

from __future__ import annotations

from datetime import datetime

from django.db import models
from django.utils import timezone
from knox.models import AbstractAuthToken
from knox.settings import CONSTANTS


class OperatorToken(AbstractAuthToken):
    """One personal API token of an operator (`Authorization: Token <token>`).

    knox keeps only `digest` (SHA-512 of the token) and `token_key`, the token's first 15
    characters (our `sst_` prefix and 11 random hex digits), indexed: the lookup is one indexed
    query on `token_key` followed by a constant-time digest compare (operators.auth).
    Revoking a token deletes it.
    """

    # knox makes the digest the primary key; an ordinary id keeps it out of admin URLs and
    # the admin's log, and the digest stays unique.
    id = models.BigAutoField(primary_key=True)
    digest = models.CharField(max_length=CONSTANTS.DIGEST_LENGTH, unique=True)
    name = models.CharField(max_length=100, help_text="What or who uses it, e.g. 'ops laptop'.")

    class Meta:
        verbose_name = "API token"
        ordering = ["-created"]

    def __str__(self) -> str:
        return f"{self.name} ({self.token_key}…)"

    def is_expired(self, now: datetime | None = None) -> bool:
        return self.expiry is not None and self.expiry <= (now or timezone.now())
