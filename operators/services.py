"""Issuing and revoking operators' API tokens: the admin and `issue_token` both call these."""

from __future__ import annotations

from datetime import timedelta

from django.contrib.auth.models import AbstractBaseUser
from django.core.exceptions import ValidationError
from django.db import transaction
from django.utils import timezone
from knox.models import get_digest_token
from knox.settings import CONSTANTS

from audit.services import audit_record
from operators.models import OperatorToken


def operator_token_issue(
    *, user: AbstractBaseUser, name: str, expires_in: timedelta | None
) -> tuple[OperatorToken, str]:
    """Issue a token for ``user``; returns (token, raw token). The raw token is never stored.

    1. knox makes the raw token (the `sst_` prefix, then 64 random hex digits) and its digest;
    2. only the digest and the first 15 characters (the indexed lookup key) are saved;
    3. ``expires_in=None`` makes a token that never expires;
    4. the audit log gets ``token.issued``, by the origin's actor (audit.context: the operator
       at the admin, the shell user of ``issue_token``), who may issue for someone else.
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
    with transaction.atomic():
        token.save(force_insert=True)
        _audit_token("token.issued", token)
    return token, raw


@transaction.atomic
def operator_token_revoke(*, token: OperatorToken) -> None:
    """Revoke a token: it is deleted, and the next request that sends it is refused. The
    audit entry (``token.revoked``) outlives it."""
    _audit_token("token.revoked", token)
    token.delete()


def _audit_token(action: str, token: OperatorToken) -> None:
    # The name and the non-secret lookup prefix name the token; the digest stays in its row.
    owner = token.user.get_username()
    audit_record(
        action=action,
        subject_type="api token",
        subject_id=token.pk,
        subject=f"{token.name} ({token.token_key}…) of {owner}",
        detail={
            "owner": owner,
            "name": token.name,
            "expiry": token.expiry.isoformat() if token.expiry else None,
        },
    )
