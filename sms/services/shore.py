"""The shore link (issue 11 §6): the numbers from the shore, the glider's SMS log to it."""

from __future__ import annotations

import datetime as dt
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from django.core.exceptions import ValidationError
from django.db import IntegrityError, transaction
from django.utils.dateparse import parse_datetime

from commands.models import Command
from sms.errors import InvalidNumber
from sms.models import RAW_NUMBER_MAX, AuthorisedNumber, Role, SmsMessage
from sms.services._common import _UNSTORABLE, DETAIL_MAX, TEXT_STORE_MAX
from sms.services.numbers import (
    authorised_number_save,
    e164_or_blank,
    number_normalise,
    validation_message,
)
from vessels.models import Vessel

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class NumbersReplaced:
    """What :func:`authorised_numbers_replace` changed on this side."""

    added: int = 0
    updated: int = 0
    removed: int = 0
    rejected: tuple[str, ...] = ()  # why each unusable entry was skipped


def _entry_expiry(value: object) -> dt.datetime | None:
    if value in (None, ""):
        return None
    if isinstance(value, dt.datetime):
        return value
    parsed = parse_datetime(str(value))
    if parsed is None or parsed.tzinfo is None:
        raise ValidationError({"expires_at": [f"{value!r} is not a date-time with an offset"]})
    return parsed


@transaction.atomic
def authorised_numbers_replace(
    *, vessel: Vessel, numbers: Sequence[Mapping[str, object]]
) -> NumbersReplaced:
    """Make ``numbers`` (the shore's list for ``vessel``: number, name, role, active,
    expires_at) the numbers that may address ``vessel`` here, in one transaction.

    The shore admin is where numbers are managed: an entry missing from the list may no longer
    address the vessel (its entry is kept, so the log still names its holder). An unusable
    entry is skipped and reported; the others are applied. Entries that did not change are not
    written.
    """
    added = updated = 0
    rejected: list[str] = []
    kept: set[str] = set()
    for raw in numbers:
        try:
            e164 = number_normalise(raw=str(raw.get("number", "")))
            name = str(raw.get("name") or e164)[:100]
            role = str(raw.get("role", ""))
            active = raw.get("active", True) is True
            expires_at = _entry_expiry(raw.get("expires_at"))
            if role not in Role.values:
                raise ValidationError({"role": [f"{role!r} is not a role"]})
        except (InvalidNumber, ValidationError) as exc:
            rejected.append(f"{raw.get('number')!r}: {exc}")
            continue
        entry = AuthorisedNumber.objects.filter(number=e164).first()
        linked = entry is not None and entry.vessels.filter(pk=vessel.pk).exists()
        wanted = {"name": name, "role": role, "active": active, "expires_at": expires_at}
        if entry is not None and linked and all(getattr(entry, k) == v for k, v in wanted.items()):
            kept.add(e164)
            continue
        vessels = [vessel] if entry is None else [*entry.vessels.exclude(pk=vessel.pk), vessel]
        fresh = entry is None
        entry = entry or AuthorisedNumber(number=e164)
        for field, value in wanted.items():
            setattr(entry, field, value)
        try:
            authorised_number_save(entry=entry, vessels=vessels)
        except ValidationError as exc:
            rejected.append(f"{e164}: {validation_message(exc)}")
            continue
        kept.add(e164)
        added += fresh
        updated += not fresh
    gone = AuthorisedNumber.objects.filter(vessels=vessel).exclude(number__in=kept)
    removed = 0
    for entry in gone:
        entry.vessels.remove(vessel)
        removed += 1
    for reason in rejected:
        logger.warning("authorised number from the shore skipped: %s", reason)
    return NumbersReplaced(added, updated, removed, tuple(rejected))


def sms_log_entry_store(*, vessel: Vessel, entry: Mapping[str, Any]) -> bool:
    """Store one entry of a vessel's uploaded SMS log (validated by the boat API); False if
    the vessel sent it before (same ``id``). Its own savepoint: a failure loses only it."""
    origin = entry["id"]
    if SmsMessage.objects.filter(vessel=vessel, origin_id=origin).exists():
        return False
    number = _UNSTORABLE.sub("\ufffd", entry["number"])[:RAW_NUMBER_MAX]
    e164 = e164_or_blank(number)
    reply_to = None
    if entry.get("reply_to"):
        reply_to = SmsMessage.objects.filter(vessel=vessel, origin_id=entry["reply_to"]).first()
    try:
        with transaction.atomic():
            message = SmsMessage.objects.create(
                origin_id=origin,
                direction=entry["direction"],
                vessel=vessel,
                number=number,
                number_e164=e164,
                authorised_number=AuthorisedNumber.objects.filter(number=e164).first()
                if e164
                else None,
                text=_UNSTORABLE.sub("\ufffd", entry.get("text", "")[:TEXT_STORE_MAX]),
                authorised=bool(entry.get("authorised")),
                outcome=entry.get("outcome", ""),
                detail=entry.get("detail", "")[:DETAIL_MAX],
                parsed=entry.get("parsed") or [],
                reply_to=reply_to,
                modem_timestamp=entry.get("modem_timestamp"),
                received_at=entry.get("received_at"),
                status=entry.get("status", ""),
                status_detail=entry.get("status_detail", "")[:DETAIL_MAX],
                reference=entry.get("reference", "")[:20],
                sent_at=entry.get("sent_at"),
            )
            # created_at is auto_now_add: the vessel's own time is written after the insert.
            SmsMessage.objects.filter(pk=message.pk).update(created_at=entry["created_at"])
            uids = entry.get("commands") or []
            if uids:
                message.commands.set(Command.objects.filter(vessel=vessel, uid__in=uids))
    except IntegrityError:
        if SmsMessage.objects.filter(vessel=vessel, origin_id=origin).exists():
            return False  # the same upload racing itself
        raise
    return True
