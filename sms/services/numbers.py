"""Phone numbers and the authorised numbers (docs/sms.md: only active authorised numbers with the
right role are answered; everything else is logged and not answered)."""

from __future__ import annotations

import datetime as dt
import functools
from collections.abc import Iterable, Sequence

import phonenumbers
from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import transaction
from django.utils import timezone

from sms.errors import InvalidNumber, NumberNotFound
from sms.models import AuthorisedNumber
from vessels.models import Vessel

_NUMBER_CACHE = 4096


@functools.lru_cache(maxsize=_NUMBER_CACHE)
def _e164(raw: str, region: str) -> str:
    try:
        parsed = phonenumbers.parse(raw, region)
    except phonenumbers.NumberParseException as exc:
        raise InvalidNumber(f"{raw!r} is not a phone number ({exc})") from None
    if not phonenumbers.is_valid_number(parsed):
        raise InvalidNumber(f"{raw!r} is not a valid phone number in {region} or abroad")
    return phonenumbers.format_number(parsed, phonenumbers.PhoneNumberFormat.E164)


def number_normalise(*, raw: str, region: str | None = None) -> str:
    """The E.164 form of a phone number written in any usual way; raises InvalidNumber.

    ``+61 412-345-678``, ``0412 345 678`` (national, read in ``region``, by default the
    setting SMS_DEFAULT_REGION) and ``0011 61 412 345 678`` all give ``+61412345678``.
    """
    return _e164(raw.strip(), region or settings.SMS_DEFAULT_REGION)


def e164_or_blank(raw: str) -> str:
    try:
        return number_normalise(raw=raw)
    except InvalidNumber:
        return ""  # an alphanumeric sender ("Telstra") or garbage: never authorised


@transaction.atomic
def authorised_number_save(
    *, entry: AuthorisedNumber, vessels: Iterable[Vessel] | None = None
) -> AuthorisedNumber:
    """Save an entry (new or edited) with its number in E.164; raises InvalidNumber or
    ValidationError. ``vessels``, when given, replaces the vessels it may address."""
    entry.number = number_normalise(raw=entry.number)
    entry.full_clean()
    entry.save()
    if vessels is not None:
        entry.vessels.set(list(vessels))
    return entry


@transaction.atomic
def authorised_number_authorise(
    *,
    number: str,
    vessels: Sequence[Vessel],
    role: str,
    name: str,
    expires_at: dt.datetime | None = None,
    notes: str | None = None,
) -> AuthorisedNumber:
    """Authorise a number for exactly these vessels (creating or updating its entry, active).

    Idempotent, for scripted provisioning (``manage.py authorise_number``).
    """
    e164 = number_normalise(raw=number)
    entry = AuthorisedNumber.objects.filter(number=e164).first() or AuthorisedNumber(number=e164)
    entry.name = name
    entry.role = role
    entry.active = True
    entry.expires_at = expires_at
    if notes is not None:
        entry.notes = notes
    return authorised_number_save(entry=entry, vessels=vessels)


def authorised_number_deauthorise(
    *, number: str | None = None, entry: AuthorisedNumber | None = None
) -> AuthorisedNumber:
    """Make an entry inactive (kept, so the log still names its holder)."""
    if entry is None:
        e164 = number_normalise(raw=number or "")
        entry = AuthorisedNumber.objects.filter(number=e164).first()
        if entry is None:
            raise NumberNotFound(f"{e164} is not an authorised number")
    AuthorisedNumber.objects.filter(pk=entry.pk).update(active=False, updated_at=timezone.now())
    entry.refresh_from_db()
    return entry


def validation_message(exc: ValidationError) -> str:
    """A ValidationError as one line for a management command."""
    if hasattr(exc, "message_dict"):
        return "; ".join(f"{k}: {' '.join(v)}" for k, v in exc.message_dict.items())
    return " ".join(exc.messages)
