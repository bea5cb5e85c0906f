"""Issuing and revoking operators' API tokens: the admin and `issue_token` both call these."""

from __future__ import annotations

from datetime import timedelta

from django.contrib.auth.models import AbstractBaseUser
from django.core.exceptions import ValidationError
from django.utils import timezone
from knox.models import get_digest_token
from knox.settings import CONSTANTS

from operators.models import OperatorToken


def operator_token_issue(
    *, user: AbstractBaseUser, name: str, expires_in: timedelta | None
) -> tuple[OperatorToken, str]:
    """Issue a token for ``user``; returns (token, raw token). The raw token is never stored.

    1. knox makes the raw token (the `sst_` prefix, then 64 random hex digits) and its digest;
    2. only the digest and the first 15 characters (the indexed lookup key) are saved;
    3. ``expires_in=None`` makes a token that never expires.
    """
    if not user.is_active:
        raise ValidationError({"user": f"{user.get_username()} is not an active user."})
    if expires_in is not None and expires_in <= timedelta(0):
        raise ValidationError({"expiry": "A token must expire in the future (or never)."})
    digest, raw = get_digest_token()
    token = OperatorToken(
        user=user,
        name=name,
        digest=digest,
        token_key=raw[: CONSTANTS.TOKEN_KEY_LENGTH],
        expiry=None if expires_in is None else timezone.now() + expires_in,
    )
    token.full_clean()
    token.save(force_insert=True)
    return token, raw


def operator_token_revoke(*, token: OperatorToken) -> None:
    """Revoke a token: it is deleted, and the next request that sends it is refused."""
    token.delete()
