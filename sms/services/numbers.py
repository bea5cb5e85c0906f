"""Phone numbers and the authorised numbers (docs/sms.md: only active authorised numbers with the
right role are answered; everything else is logged and not answered)."""

from __future__ import annotations

import datetime as dt
import functools
from collections.abc import Iterable, Sequence
from typing import Any

import phonenumbers
from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import transaction
from django.utils import timezone

from audit.services import audit_record
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
    ValidationError. ``vessels``, when given, replaces the vessels it may address.

    Audited (by the origin's actor: audit.context) as ``number.added``, or ``number.changed``
    with each changed field's old and new value; a save that changes nothing is not logged.
    """
    entry.number = number_normalise(raw=entry.number)
    entry.full_clean()
    before = _as_audited(entry.pk) if entry.pk else None
    entry.save()
    if vessels is not None:
        entry.vessels.set(list(vessels))
    after = _as_audited(entry.pk)
    if before is None:
        _audit_number("number.added", entry, after["vessels"], detail=after)
    elif changes := {k: [before[k], v] for k, v in after.items() if before[k] != v}:
        _audit_number("number.changed", entry, after["vessels"], detail={"changes": changes})
    return entry


# What an entry's audit detail shows; notes only as changed or not (free text, any length).
_AUDITED = ["number", "name", "role", "active", "expires_at", "receives_positions"]


def _as_audited(pk: int) -> dict[str, Any]:
    row = AuthorisedNumber.objects.filter(pk=pk).values(*_AUDITED, "notes").get()
    row["expires_at"] = row["expires_at"].isoformat() if row["expires_at"] else None
    row["notes"] = "set" if row["notes"] else ""
    row["vessels"] = sorted(
        AuthorisedNumber.vessels.through.objects.filter(authorisednumber_id=pk).values_list(
            "vessel__slug", flat=True
        )
    )
    return row


def _audit_number(
    action: str, entry: AuthorisedNumber, slugs: Sequence[str], detail: dict[str, Any]
) -> None:
    audit_record(
        action=action,
        subject_type="authorised number",
        subject_id=entry.pk,
        subject=f"{entry.name} ({entry.number})",
        # The vessel column holds one slug: a number for several names them in its detail.
        vessel=slugs[0] if len(slugs) == 1 else "",
        detail=detail,
    )


@transaction.atomic
def authorised_number_authorise(
    *,
    number: str,
    vessels: Sequence[Vessel],
    role: str,
    name: str,
    expires_at: dt.datetime | None = None,
    notes: str | None = None,
    receives_positions: bool | None = None,
) -> AuthorisedNumber:
    """Authorise a number for exactly these vessels (creating or updating its entry, active).

    Idempotent, for scripted provisioning (``manage.py authorise_number``). ``notes`` and
    ``receives_positions`` left None keep what the entry had.
    """
    e164 = number_normalise(raw=number)
    entry = AuthorisedNumber.objects.filter(number=e164).first() or AuthorisedNumber(number=e164)
    entry.name = name
    entry.role = role
    entry.active = True
    entry.expires_at = expires_at
    if notes is not None:
        entry.notes = notes
    if receives_positions is not None:
        entry.receives_positions = receives_positions
    return authorised_number_save(entry=entry, vessels=vessels)


@transaction.atomic
def authorised_number_deauthorise(
    *, number: str | None = None, entry: AuthorisedNumber | None = None
) -> AuthorisedNumber:
    """Make an entry inactive (kept, so the log still names its holder); audited as
    ``number.deauthorised`` when it was active."""
    if entry is None:
        e164 = number_normalise(raw=number or "")
        entry = AuthorisedNumber.objects.filter(number=e164).first()
        if entry is None:
            raise NumberNotFound(f"{e164} is not an authorised number")
    # Conditional: an entry already inactive is left alone, and logged once only.
    changed = AuthorisedNumber.objects.filter(pk=entry.pk, active=True).update(
        active=False, updated_at=timezone.now()
    )
    entry.refresh_from_db()
    if changed:
        slugs = _as_audited(entry.pk)["vessels"]
        _audit_number("number.deauthorised", entry, slugs, detail={"vessels": slugs})
    return entry


@transaction.atomic
def authorised_number_delete(*, entry: AuthorisedNumber) -> None:
    """Delete an entry (the SMS log keeps the number it was sent from); audited as
    ``number.removed`` with what the entry held."""
    held = _as_audited(entry.pk)
    _audit_number("number.removed", entry, held["vessels"], detail=held)
    entry.delete()


def validation_message(exc: ValidationError) -> str:
    """A ValidationError as one line for a management command."""
    if hasattr(exc, "message_dict"):
        return "; ".join(f"{k}: {' '.join(v)}" for k, v in exc.message_dict.items())
    return " ".join(exc.messages)
