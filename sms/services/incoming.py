"""The one entry point for an incoming SMS: de-duplicate, identify the sender, rate-limit, parse,
carry the commands out, and log it; :mod:`sms.services.replies` says what is answered and when."""

from __future__ import annotations

import datetime as dt
import functools
import hashlib
import logging
import uuid
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import IntegrityError, transaction
from django.db.models import Exists, OuterRef

from commands.errors import CommandError
from commands.models import Command, Source
from commands.services import command_enqueue
from edge_client.contract.kinds import WAVE_GLIDER
from sms import command_text, language
from sms.language import Answer, Item, ItemKind
from sms.level2.inner import InnerCommandTable
from sms.models import RAW_NUMBER_MAX, AuthorisedNumber, Direction, Outcome, Role, SmsMessage
from sms.services import replies as replying
from sms.services._common import (
    DETAIL_MAX,
    TEXT_STORE_MAX,
    _save_checked,
)
from sms.services.numbers import e164_or_blank
from vessels.models import Vessel
from vessels.text import replace_unstorable

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class SmsOutcome:
    """What an incoming SMS led to: its log entry, the replies to send, the commands queued."""

    message: SmsMessage
    replies: tuple[SmsMessage, ...] = ()
    commands: tuple[Command, ...] = ()
    duplicate: bool = False  # delivered before: this is what the first delivery got

    @property
    def outcome(self) -> str:
        return self.message.outcome

    @property
    def reply_texts(self) -> list[str]:
        return [reply.text for reply in self.replies]


@functools.cache
def shipped_table() -> InnerCommandTable:
    """The glider's inner command table as shipped (sms/level2/inner_commands.toml)."""
    return InnerCommandTable.load()


def sms_handle_incoming(
    *,
    vessel: Vessel,
    number: str,
    text: str,
    received_at: dt.datetime,
    modem_timestamp: dt.datetime | None = None,
    table: InnerCommandTable | None = None,
    send_replies: bool = True,
    reply_window_s: float = 0.0,
    readings: Mapping[str, float] | None = None,
    shore_key_hash: str | None = None,
) -> SmsOutcome:
    """Handle one SMS that reached ``vessel``'s modem; the one way in for every SMS.

    1. A delivery seen before (same vessel, number, text and modem time stamp: a modem
       re-reading its store) returns what the first one got and creates nothing.
    2. The sender is looked up by E.164 number: a stranger, an inactive, expired or other
       vessel's number is logged and gets no reply at all (a stranger learns nothing).
    3. A number past SMS_RATE_LIMIT answered messages in SMS_RATE_WINDOW_S is logged, not
       answered; the first such text gets one notice saying when it is answered again
       (:func:`sms.services.replies.rate_notice`), the others nothing.
    4. The text is parsed (:mod:`sms.language`, checked against the glider's inner command
       ``table``, the shipped one by default); a query-role number that commands is refused.
    5. Commands are queued (source ``sms``, created by the number), queries answered from
       the vessel's known state, and one reply is stored as pending for the modem
       (``send_replies=False``: stored as not to be sent, for ``sms_inject``).
    6. With a ``reply_window_s`` (the bridge's), a reply with commands is held as ``waiting``
       for their outcome until the window passes (:func:`sms_replies_due`), so that it can
       say ``OK`` or ``FAILED …`` rather than ``QUEUED``. ``readings`` (the glider's live
       sensor readings) answer ``#STATUS`` before the last fix's.
    7. A text ending with a shore reference (``ref:…``, :mod:`sms.command_text`: the shore
       texted one of its commands) is that one command, queued under the shore command's uid
       and created by ``shore``, once the reference's MAC verifies under ``shore_key_hash``
       (the SHA-256 hex of the key the glider's shore link presents). A reference that does
       not verify (another key, the command changed under it, an old unsigned one, no key
       here) is not the shore's: the whole text is refused with an error, nothing runs, and
       it is logged. A uid known here already is answered ``DUPLICATE`` when the SMS says the
       same command (kind and parameters), refused with an error when it does not.

    Everything is written in one transaction.
    """
    text = replace_unstorable(text[:TEXT_STORE_MAX])
    number = replace_unstorable(number.strip())[:RAW_NUMBER_MAX]
    key = _delivery_key(vessel, number, text, modem_timestamp)
    if key and (seen := _delivered(key)):
        return seen
    if table is None and vessel.kind == WAVE_GLIDER:
        table = shipped_table()
    try:
        with transaction.atomic():
            return _handle(
                vessel=vessel,
                number=number,
                text=text,
                received_at=received_at,
                modem_timestamp=modem_timestamp,
                key=key,
                table=table if vessel.kind == WAVE_GLIDER else None,
                send_replies=send_replies,
                reply_window_s=reply_window_s,
                readings=readings,
                shore_key_hash=shore_key_hash,
            )
    except IntegrityError:
        # Two deliveries of one SMS racing: the other one committed first.
        seen = _delivered(key) if key else None
        if seen is None:
            raise
        logger.info("SMS from %s delivered twice at once; handled once", number)
        return seen


def _delivery_key(
    vessel: Vessel, number: str, text: str, modem_timestamp: dt.datetime | None
) -> str | None:
    if modem_timestamp is None:
        return None
    stamp = modem_timestamp.astimezone(dt.UTC).isoformat()
    raw = "\x1f".join([str(vessel.pk), number, stamp, text])
    return hashlib.sha256(raw.encode("utf-8", "surrogatepass")).hexdigest()


def _delivered(key: str) -> SmsOutcome | None:
    # Asked of every SMS and almost always "no": one lookup on the unique index.
    message = SmsMessage.objects.filter(delivery_key=key).first()
    if message is None:
        return None
    return SmsOutcome(
        message=message,
        replies=tuple(message.replies.order_by("pk")),
        commands=tuple(message.commands.order_by("pk")),
        duplicate=True,
    )


def _handle(
    *,
    vessel: Vessel,
    number: str,
    text: str,
    received_at: dt.datetime,
    modem_timestamp: dt.datetime | None,
    key: str | None,
    table: InnerCommandTable | None,
    send_replies: bool,
    reply_window_s: float = 0.0,
    readings: Mapping[str, float] | None = None,
    shore_key_hash: str | None = None,
) -> SmsOutcome:
    e164 = e164_or_blank(number)
    message = SmsMessage(
        direction=Direction.IN,
        vessel=vessel,
        number=number,
        number_e164=e164,
        text=text,
        modem_timestamp=modem_timestamp,
        received_at=received_at,
        delivery_key=key,
    )
    entry, refusal = _identify(e164, vessel, received_at)
    message.authorised_number = entry
    if entry is None:
        return _logged(message, Outcome.STRANGER)
    if refusal:
        return _logged(message, Outcome.REFUSED, refusal)
    until = _rate_limited_until(e164, received_at)
    if until is not None:
        message.authorised = True
        limit = f"more than {settings.SMS_RATE_LIMIT} in {settings.SMS_RATE_WINDOW_S} s"
        again = f"answered again from {until.astimezone(dt.UTC):%Y-%m-%d %H:%M:%S} UTC"
        logged = _logged(message, Outcome.RATE_LIMITED, f"{limit}; {again}")
        notice = replying.rate_notice(message, entry, until, send_replies=send_replies)
        return replace(logged, replies=(notice,) if notice else ())
    rest, token = command_text.split_reference(text)
    shore_uid = None
    if token is not None:
        shore_uid = command_text.verified_uid(rest, token, shore_key_hash)
    if token is not None and shore_uid is None:
        items = [_not_ours(number, token, has_key=bool(shore_key_hash))]
    else:
        items = language.parse(rest, vessel_kind=vessel.kind, table=table)
    if shore_uid is not None:
        items = _one_shore_command(items, shore_uid)
    message.parsed = [item.as_dict() for item in items]
    if shore_uid is not None:
        message.parsed[0]["shore_uid"] = str(shore_uid)
    if entry.role != Role.CONTROL and any(item.commanding for item in items):
        return _logged(message, Outcome.REFUSED, "query role: may not command")
    message.authorised = True
    answers, queued = _carry_out(
        items, vessel=vessel, sender=e164, now=received_at, readings=readings, shore_uid=shore_uid
    )
    commands = [command for _, command in queued]
    message.outcome = Outcome.ERROR if any(a.error for a in answers) else Outcome.ACCEPTED
    _save_checked(message)
    reply = replying.reply_store(
        message=message,
        entry=entry,
        answers=answers,
        queued=queued,
        send_replies=send_replies,
        reply_window_s=reply_window_s,
    )
    if commands:
        link = SmsMessage.commands.through
        link.objects.bulk_create(
            [link(smsmessage=m, command=c) for m in (message, reply) for c in commands]
        )
    return SmsOutcome(message=message, replies=(reply,), commands=tuple(commands))


def _logged(message: SmsMessage, outcome: Outcome, detail: str = "") -> SmsOutcome:
    message.outcome = outcome
    message.detail = detail[:DETAIL_MAX]
    _save_checked(message)
    return SmsOutcome(message=message)


def _identify(e164: str, vessel: Vessel, now: dt.datetime) -> tuple[AuthorisedNumber | None, str]:
    """The sender's entry (None: a stranger) and why it may not use this vessel ("" if it may)."""
    if not e164:
        return None, ""
    # number is unique: at most one row, with whether it may use this vessel in the same read.
    allowed = AuthorisedNumber.vessels.through.objects.filter(
        authorisednumber=OuterRef("pk"), vessel=vessel
    )
    entry = (
        AuthorisedNumber.objects.filter(number=e164).annotate(for_vessel=Exists(allowed)).first()
    )
    if entry is None:
        return None, ""
    if not entry.active:
        return entry, "number inactive"
    if entry.expires_at is not None and entry.expires_at <= now:
        return entry, f"authorisation expired {entry.expires_at:%Y-%m-%d %H:%M} UTC"
    if not entry.for_vessel:
        return entry, f"not authorised for {vessel.slug}"
    return entry, ""


def _rate_limited_until(e164: str, now: dt.datetime) -> dt.datetime | None:
    """When the number's texts are answered again, or None when this one is answered.

    Only the messages the limit let through count (not the ones it held back): so the time a
    notice gives stays true however often the number texts meanwhile. With the limit-th newest
    of them at ``t``, a text at ``t + window`` or later finds fewer than the limit in its window.
    """
    limit, window = settings.SMS_RATE_LIMIT, settings.SMS_RATE_WINDOW_S
    if limit <= 0:
        return None
    since = now - dt.timedelta(seconds=window)
    # The limit-th row, newest first, of the partial index sms_in_rate_count (the filter is
    # the index's own condition): bounded however many a flood sent.
    counted = (
        SmsMessage.objects.filter(
            direction=Direction.IN,
            number_e164=e164,
            received_at__gt=since,
            received_at__lte=now,
        )
        .exclude(outcome=Outcome.RATE_LIMITED)
        .order_by("-received_at")
        .values_list("received_at", flat=True)
    )
    oldest = next(iter(counted[limit - 1 : limit]), None)
    if oldest is None:
        return None
    return oldest + dt.timedelta(seconds=window)


def _carry_out(
    items: Sequence[Item],
    *,
    vessel: Vessel,
    sender: str,
    now: dt.datetime,
    readings: Mapping[str, float] | None = None,
    shore_uid: uuid.UUID | None = None,
) -> tuple[list[Answer], list[tuple[int, Command]]]:
    """One answer per item, in order, and the commands queued (with their answer's index).
    With ``shore_uid`` (the SMS carried the shore's reference) its one command is the shore's:
    see :func:`_take_from_shore`."""
    answers: list[Answer] = []
    queued: list[tuple[int, Command]] = []
    for item in items:
        if item.kind == ItemKind.COMMAND and shore_uid is not None:
            answer, taken = _take_from_shore(item, vessel=vessel, uid=shore_uid)
            if taken is not None:
                queued.append((len(answers), taken))
            answers.append(answer)
        elif item.kind == ItemKind.COMMAND:
            try:
                command = command_enqueue(
                    vessel=vessel,
                    kind=item.command,
                    params=dict(item.params),
                    source=Source.SMS,
                    created_by=sender,
                )
            except CommandError as exc:  # the vessel was made inactive, …
                answers.append(language.answer_command(item, f"ERR {exc.message}", error=True))
                continue
            queued.append((len(answers), command))
            answers.append(language.answer_command(item, "QUEUED"))
        else:
            answers.append(replying.answer_item(vessel, item, now, readings))
    replying.say_superseded(answers, queued)
    return answers, queued


def _not_ours(number: str, token: str, *, has_key: bool) -> Item:
    """The one item of a text whose reference does not verify: an error, so nothing in it
    runs (not even a command before it: the text is not what the shore sent, if it ever did)."""
    why = (
        "not signed with this glider's shore key, or the text was changed"
        if has_key
        else "no shore key is configured here to check it"
    )
    logger.warning("SMS from %s: reference %s does not verify (%s); refused", number, token, why)
    return Item(ItemKind.ERROR, "", error="ref not valid: text refused", commanding=True)


def _one_shore_command(items: list[Item], uid: uuid.UUID) -> list[Item]:
    """The items of an SMS that carries a shore reference: one command (or its refusal), or
    one error; a reference names one command, never a query or several."""
    if len(items) == 1 and items[0].kind in (ItemKind.COMMAND, ItemKind.ERROR) and items[0].command:
        return items
    reason = f"a shore reference goes with one command (ref {uid})"
    return [Item(ItemKind.ERROR, "", error=reason, commanding=True)]


def _take_from_shore(
    item: Item, *, vessel: Vessel, uid: uuid.UUID
) -> tuple[Answer, Command | None]:
    """Queue an SMS's command as the shore's own, under the shore's uid (created by
    ``shore``: the shore link acks it up by uid, and never queues that uid again from a poll);
    a uid known here already is answered as a duplicate and not run twice, or refused when the
    SMS says another command than the one known under it."""
    known = _known_answer(item, vessel=vessel, uid=uid)
    if known is not None:
        return known, None
    try:
        with transaction.atomic():  # a savepoint: a poll of the same uid racing this one
            command = command_enqueue(
                vessel=vessel,
                kind=item.command,
                params=dict(item.params),
                source=Source.SMS,
                created_by=command_text.SHORE_CREATED_BY,
                uid=uid,
            )
    except (IntegrityError, ValidationError):
        logger.info("shore command %s came by SMS and by the shore link at once", uid)
        known = _known_answer(item, vessel=vessel, uid=uid)
        return known or language.answer_command(item, "DUPLICATE (queued here)"), None
    except CommandError as exc:
        return language.answer_command(item, f"ERR {exc.message}", error=True), None
    return language.answer_command(item, "QUEUED"), command


def _known_answer(item: Item, *, vessel: Vessel, uid: uuid.UUID) -> Answer | None:
    """The answer to a shore reference whose uid is known here already (None: it is not):
    another vessel's command, a different command (refused and logged: the shore's reference
    cannot name two commands), or the same one (a duplicate, not run twice)."""
    known = (
        Command.objects.filter(uid=uid).values_list("vessel_id", "status", "kind", "params").first()
    )
    if known is None:
        return None
    vessel_id, status, kind, params = known
    if vessel_id != vessel.pk:
        return language.answer_command(item, "ERR ref names another vessel's command", error=True)
    if not command_text.same_command(item.command, item.params, kind, params):
        logger.warning(
            "SMS reference %s says %s %s, but %s %s is known here under that uid; refused",
            uid, item.command, dict(item.params), kind, params,
        )  # fmt: skip
        return language.answer_command(item, "ERR ref names another command here", error=True)
    return language.answer_command(item, f"DUPLICATE ({status} here)")
