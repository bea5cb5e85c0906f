"""The shore link (issue 11 §6): the numbers from the shore, the glider's SMS log to it (one
batch, one answer: :func:`sms_log_upload`)."""

from __future__ import annotations

import datetime as dt
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import IntegrityError, transaction
from django.utils import timezone
from django.utils.dateparse import parse_datetime

from audit.context import Origin, audit_origin
from audit.models import ActorKind
from commands.models import Command
from edge_client.contract.batch import BatchAnswer
from links.models import Transport
from links.services import link_count
from sms.command_text import read_reference, split_reference
from sms.errors import InvalidNumber
from sms.gsm7 import on_air
from sms.models import RAW_NUMBER_MAX, AuthorisedNumber, Direction, Role, SendStatus, SmsMessage
from sms.services._common import DETAIL_MAX, TEXT_STORE_MAX, _save_checked
from sms.services.numbers import (
    _as_audited,
    _audit_number,
    authorised_number_save,
    e164_or_blank,
    number_normalise,
    validation_message,
)
from vessels.batch import Unreadable
from vessels.clock import check_plausible
from vessels.models import Vessel
from vessels.text import replace_unstorable

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
    expires_at, receives_positions) the numbers that may address ``vessel`` here, in one
    transaction. A list without ``receives_positions`` (a shore older than the flag) leaves
    the flag here as it is.

    The shore admin is where numbers are managed: an entry missing from the list may no longer
    address the vessel (its entry is kept, so the log still names its holder). An unusable
    entry is skipped and reported; the others are applied. Entries that did not change are not
    written. Its audit entries (a glider's own log) name the shore as who changed them.
    """
    with audit_origin(SHORE_ORIGIN):
        return _numbers_replace(vessel, numbers)


SHORE_ORIGIN = Origin(actor="shore", actor_kind=ActorKind.SYSTEM, via="shore")


def _numbers_replace(vessel: Vessel, numbers: Sequence[Mapping[str, object]]) -> NumbersReplaced:
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
        if "receives_positions" in raw:
            wanted["receives_positions"] = raw["receives_positions"] is True
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
        was = _as_audited(entry.pk)["vessels"] + [vessel.slug]
        now = sorted(slug for slug in was if slug != vessel.slug)
        _audit_number("number.changed", entry, now, {"changes": {"vessels": [sorted(was), now]}})
    for reason in rejected:
        logger.warning("authorised number from the shore skipped: %s", reason)
    return NumbersReplaced(added, updated, removed, tuple(rejected))


# The times an uploaded SMS log entry may carry; each must be plausible (the fixes' rule).
SMS_TIMES = ("created_at", "received_at", "modem_timestamp", "sent_at")


def sms_log_upload(
    *,
    vessel: Vessel,
    entries: Sequence[Mapping[str, Any] | Unreadable],
    now: dt.datetime | None = None,
) -> BatchAnswer:
    """Store a batch of ``vessel``'s SMS log (the entries as the boat API read them) and
    answer it: a new entry is accepted; one the vessel sent before (same ``id``, in an
    earlier upload or earlier in this one) is a duplicate; an unreadable one, or one that
    breaks a rule (:func:`sms_log_check`) or the model's checks, is rejected by its index
    and never costs the others."""
    now = now or timezone.now()
    answer = BatchAnswer()
    seen: set[str] = set()
    for index, entry in enumerate(entries):
        if isinstance(entry, Unreadable):
            answer.reject(index, entry.errors)
            continue
        try:
            sms_log_check(entry, now=now)
        except ValidationError as exc:
            answer.reject(index, exc.message_dict)
            continue
        if entry["id"] in seen:
            answer.duplicates += 1
            continue
        seen.add(entry["id"])
        try:
            stored = sms_log_entry_store(vessel=vessel, entry=entry)
        except ValidationError as exc:
            answer.reject(index, exc.message_dict)
            continue
        if stored:
            answer.accepted += 1
        else:
            answer.duplicates += 1
    return answer


def sms_log_check(entry: Mapping[str, Any], *, now: dt.datetime) -> None:
    """The rules an uploaded entry keeps beyond its wire shape; ValidationError names the
    field. Its times are plausible (a reset clock's stamp is not kept, as for fixes); only
    an outgoing SMS has a status, and it must; only an incoming one has an outcome."""
    for name in SMS_TIMES:
        if entry.get(name) is not None:
            try:
                check_plausible(entry[name], now=now, max_future_s=settings.FIX_MAX_FUTURE_S)
            except ValueError as exc:
                raise ValidationError({name: [f"{name} {exc}"]}) from None
    status = entry.get("status", "")
    if entry["direction"] == Direction.IN and status:
        raise ValidationError({"status": ["only an outgoing SMS has a status"]})
    if entry["direction"] == Direction.OUT and not status:
        raise ValidationError({"status": ["an outgoing SMS needs its status"]})
    if entry["direction"] == Direction.OUT and entry.get("outcome"):
        raise ValidationError({"outcome": ["only an incoming SMS has one"]})


def _count_on_link(vessel: Vessel, entry: Mapping[str, Any]) -> None:
    """A newly stored entry on the vessel's SMS link (links app), on the UTC day it went over
    the air: the text's bytes as sent (GSM-7 packed or UCS-2) and its segments as credits. An
    outgoing SMS costs only once the modem sent it."""
    nbytes, segments = on_air(entry.get("text", ""))
    if entry["direction"] == Direction.IN:
        at = entry.get("received_at") or entry.get("modem_timestamp") or entry["created_at"]
        if _sent_from_here(vessel, entry.get("text", "")):
            # The shore's own command SMS, as the glider got it: counted when the shore sent it.
            link_count(vessel_id=vessel.pk, transport=Transport.SMS, at=at, contact=True)
            return
        link_count(vessel_id=vessel.pk, transport=Transport.SMS, at=at, contact=True,
                   messages_in=1, bytes_in=nbytes, credits=segments)  # fmt: skip
    elif entry.get("status") == SendStatus.SENT:
        at = entry.get("sent_at") or entry["created_at"]
        link_count(vessel_id=vessel.pk, transport=Transport.SMS, at=at,
                   messages_out=1, bytes_out=nbytes, credits=segments)  # fmt: skip


def _sent_from_here(vessel: Vessel, text: str) -> bool:
    """Whether an SMS the glider received is one the shore sent it (sms_send_command): its
    text carries the reference of a command of the vessel that this shore texted, sent."""
    _rest, token = split_reference(text)
    ref = read_reference(token) if token else None
    if ref is None:
        return False
    return SmsMessage.objects.filter(
        vessel=vessel,
        direction=Direction.OUT,
        origin_id__isnull=True,
        status=SendStatus.SENT,
        commands__uid=ref.uid,
        text=text,
    ).exists()


def sms_log_entry_store(*, vessel: Vessel, entry: Mapping[str, Any]) -> bool:
    """Store one entry of a vessel's uploaded SMS log (read by the boat API, checked by
    :func:`sms_log_check`); False if the vessel sent it before (same ``id``). Raises
    ValidationError when the model refuses it. Its own savepoint: a failure loses only it."""
    origin = entry["id"]
    if SmsMessage.objects.filter(vessel=vessel, origin_id=origin).exists():
        return False
    number = replace_unstorable(entry["number"])[:RAW_NUMBER_MAX]
    e164 = e164_or_blank(number)
    reply_to = None
    if entry.get("reply_to"):
        reply_to = SmsMessage.objects.filter(vessel=vessel, origin_id=entry["reply_to"]).first()
    try:
        with transaction.atomic():
            message = SmsMessage(
                origin_id=origin,
                direction=entry["direction"],
                vessel=vessel,
                number=number,
                number_e164=e164,
                authorised_number=AuthorisedNumber.objects.filter(number=e164).first()
                if e164
                else None,
                text=replace_unstorable(entry.get("text", "")[:TEXT_STORE_MAX]),
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
            _save_checked(message)
            # created_at is auto_now_add: the vessel's own time is written after the insert.
            SmsMessage.objects.filter(pk=message.pk).update(created_at=entry["created_at"])
            uids = entry.get("commands") or []
            if uids:
                message.commands.set(Command.objects.filter(vessel=vessel, uid__in=uids))
            _count_on_link(vessel, entry)
    except IntegrityError:
        if SmsMessage.objects.filter(vessel=vessel, origin_id=origin).exists():
            return False  # the same upload racing itself
        raise
    return True
