"""SMS writes: the one entry point for an incoming SMS, the outgoing queue the modem loop sends,
and the authorised numbers (DESIGN §7: only active authorised numbers with the right role are
answered; everything else is logged and not answered).
"""

from __future__ import annotations

import datetime as dt
import functools
import hashlib
import logging
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import phonenumbers
from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import IntegrityError, connection, transaction
from django.db.models import OuterRef, Subquery
from django.utils import timezone
from django.utils.dateparse import parse_datetime

from commands import catalog
from commands.errors import CatalogError, CommandError
from commands.lifecycle import Status
from commands.models import Command, CommandEvent, Source
from commands.services import command_enqueue
from sms import language, replies, selectors
from sms.errors import InvalidNumber, NumberNotFound
from sms.language import Answer, Item, ItemKind
from sms.level2.inner import InnerCommandTable
from sms.models import (
    RAW_NUMBER_MAX,
    AuthorisedNumber,
    Direction,
    Outcome,
    Role,
    SendStatus,
    SmsMessage,
)
from vessels.kinds import WAVE_GLIDER
from vessels.models import Vessel

logger = logging.getLogger(__name__)

# Longer texts are stored cut (and refused whole by the language, which reads MAX_TEXT).
TEXT_STORE_MAX = 4000
DETAIL_MAX = 200
# NUL and the UTF-16 surrogate range: PostgreSQL cannot store either as text.
_UNSTORABLE = re.compile("[\x00\ud800-\udfff]")
_NUMBER_CACHE = 4096


# -- numbers ----------------------------------------------------------------------------------


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


def _e164_or_blank(raw: str) -> str:
    try:
        return number_normalise(raw=raw)
    except InvalidNumber:
        return ""  # an alphanumeric sender ("Telstra") or garbage: never authorised


# -- incoming ---------------------------------------------------------------------------------


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
) -> SmsOutcome:
    """Handle one SMS that reached ``vessel``'s modem; the one way in for every SMS.

    1. A delivery seen before (same vessel, number, text and modem time stamp: a modem
       re-reading its store) returns what the first one got and creates nothing.
    2. The sender is looked up by E.164 number: a stranger, an inactive, expired or other
       vessel's number is logged and gets no reply at all (a stranger learns nothing).
    3. A number past SMS_RATE_LIMIT answered messages in SMS_RATE_WINDOW_S is logged, not
       answered; the first such text gets one notice saying when it is answered again
       (:func:`_rate_notice`), the others nothing.
    4. The text is parsed (:mod:`sms.language`, checked against the glider's inner command
       ``table``, the shipped one by default); a query-role number that commands is refused.
    5. Commands are queued (source ``sms``, created by the number), queries answered from
       the vessel's known state, and one reply is stored as pending for the modem
       (``send_replies=False``: stored as not to be sent, for ``sms_inject``).
    6. With a ``reply_window_s`` (the bridge's), a reply with commands is held as ``waiting``
       for their outcome until the window passes (:func:`sms_replies_due`), so that it can
       say ``OK`` or ``FAILED …`` rather than ``QUEUED``. ``readings`` (the glider's live
       sensor readings) answer ``#STATUS`` before the last fix's.

    Everything is written in one transaction.
    """
    text = _UNSTORABLE.sub("\ufffd", text[:TEXT_STORE_MAX])
    number = _UNSTORABLE.sub("\ufffd", number.strip())[:RAW_NUMBER_MAX]
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
    # Asked of every SMS and almost always "no": look for the key alone (the unique index
    # answers it), and read the message only when there is one.
    if _scalar(f"SELECT 1 FROM {_SMS} WHERE delivery_key = %s", [key]) is None:
        return None
    message = SmsMessage.objects.get(delivery_key=key)
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
) -> SmsOutcome:
    e164 = _e164_or_blank(number)
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
        notice = _rate_notice(message, entry, until, send_replies=send_replies)
        return replace(logged, replies=(notice,) if notice else ())
    items = language.parse(text, vessel_kind=vessel.kind, table=table)
    message.parsed = [item.as_dict() for item in items]
    if entry.role != Role.CONTROL and any(item.commanding for item in items):
        return _logged(message, Outcome.REFUSED, "query role: may not command")
    message.authorised = True
    answers, queued = _carry_out(
        items, vessel=vessel, sender=e164, now=received_at, readings=readings
    )
    commands = [command for _, command in queued]
    message.outcome = Outcome.ERROR if any(a.error for a in answers) else Outcome.ACCEPTED
    # Built here from bounded values; full_clean() would cost a query per foreign key.
    message.save()
    by_answer = {index: command.pk for index, command in queued}
    status = SendStatus.PENDING if send_replies else SendStatus.NOT_SENT
    hold = send_replies and reply_window_s > 0 and any(c.status in _OPEN_STATUSES for c in commands)
    reply = SmsMessage.objects.create(
        direction=Direction.OUT,
        vessel=vessel,
        number=e164,
        number_e164=e164,
        authorised_number=entry,
        authorised=True,
        text=language.compose_reply(answers),
        parsed=[replies.answer_record(a, by_answer.get(i)) for i, a in enumerate(answers)],
        reply_to=message,
        status=SendStatus.WAITING if hold else status,
        status_detail="" if send_replies else "shown by sms_inject, not sent",
        due_at=received_at + dt.timedelta(seconds=reply_window_s) if hold else None,
    )
    if commands:
        link = SmsMessage.commands.through
        link.objects.bulk_create(
            [link(smsmessage=m, command=c) for m in (message, reply) for c in commands]
        )
    return SmsOutcome(message=message, replies=(reply,), commands=tuple(commands))


_OPEN_STATUSES = frozenset({"queued", "sent", "acknowledged"})


def _logged(message: SmsMessage, outcome: Outcome, detail: str = "") -> SmsOutcome:
    message.outcome = outcome
    message.detail = detail[:DETAIL_MAX]
    message.save()
    return SmsOutcome(message=message)


def _identify(e164: str, vessel: Vessel, now: dt.datetime) -> tuple[AuthorisedNumber | None, str]:
    """The sender's entry (None: a stranger) and why it may not use this vessel ("" if it may)."""
    if not e164:
        return None, ""
    # number is unique: at most one row. Written out (see _scalar): building it with the ORM,
    # an Exists() annotation, took more time than any other step of handling an SMS.
    found = AuthorisedNumber.objects.raw(
        f"SELECT a.*, EXISTS (SELECT 1 FROM {_ALLOWED} v WHERE v.authorisednumber_id = a.id "
        f"AND v.vessel_id = %s) AS for_vessel FROM {_NUMBERS} a WHERE a.number = %s",
        [vessel.pk, e164],
    )
    entry = next(iter(found), None)
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
    # The limit-th row, newest first, of the partial index sms_in_rate_count (its condition
    # written as the index's own literals so the planner can use it): bounded however many a
    # flood sent.
    oldest = _scalar(
        f"SELECT received_at FROM {_SMS} WHERE direction = 'in' AND NOT outcome = "
        "'rate_limited' AND number_e164 = %s AND received_at > %s AND received_at <= %s "
        "ORDER BY received_at DESC LIMIT 1 OFFSET %s",
        [e164, _stamp(since), _stamp(now), limit - 1],
    )
    if oldest is None:
        return None
    if isinstance(oldest, str):  # SQLite hands the raw text back
        oldest = parse_datetime(oldest)
    if timezone.is_naive(oldest):
        oldest = timezone.make_aware(oldest, dt.UTC)
    return oldest + dt.timedelta(seconds=window)


def _rate_notice(
    message: SmsMessage, entry: AuthorisedNumber, until: dt.datetime, *, send_replies: bool
) -> SmsMessage | None:
    """The one SMS telling a rate-limited number when it is answered again (issue 16 §14).

    Once per ``until``: every text held back until then computes the same ``until`` (the
    messages that count do not change meanwhile), and the notice's ``delivery_key`` names it,
    so the unique index lets one notice in, whatever retries or a concurrent handler do. A
    racing twin waits on PostgreSQL's index entry (SQLite: on the write lock) and then fails
    inside its own savepoint, leaving the rest of its transaction whole.
    """
    key = f"rate:{message.number_e164}:{until.astimezone(dt.UTC):%Y%m%dT%H%M%S.%f}"
    if _scalar(f"SELECT 1 FROM {_SMS} WHERE delivery_key = %s", [key]) is not None:
        return None  # told already
    text = replies.rate_limit_notice(
        limit=settings.SMS_RATE_LIMIT,
        window_s=settings.SMS_RATE_WINDOW_S,
        until=until,
        now=message.received_at or until,
    )
    try:
        with transaction.atomic():
            return SmsMessage.objects.create(
                direction=Direction.OUT,
                vessel=message.vessel,
                number=message.number_e164,
                number_e164=message.number_e164,
                authorised_number=entry,
                authorised=True,
                text=text,
                reply_to=message,
                delivery_key=key,
                status=SendStatus.PENDING if send_replies else SendStatus.NOT_SENT,
                status_detail="rate limit notice"
                if send_replies
                else "rate limit notice shown by sms_inject, not sent",
            )
    except IntegrityError:
        return None  # a concurrent text of the same number sent it


# The three reads every SMS makes, written out: each is one indexed lookup, and the ORM's
# building of them (not the database) was most of the time an SMS took (bench.sms).
_SMS = connection.ops.quote_name(SmsMessage._meta.db_table)
_NUMBERS = connection.ops.quote_name(AuthorisedNumber._meta.db_table)
_ALLOWED = connection.ops.quote_name(AuthorisedNumber.vessels.through._meta.db_table)


def _scalar(sql: str, params: Sequence[object]) -> Any:
    """The first column of the first row, or None when there is no row."""
    with connection.cursor() as cursor:
        cursor.execute(sql, params)
        row = cursor.fetchone()
    return None if row is None else row[0]


def _stamp(when: dt.datetime) -> Any:
    return connection.ops.adapt_datetimefield_value(when)


def _carry_out(
    items: Sequence[Item],
    *,
    vessel: Vessel,
    sender: str,
    now: dt.datetime,
    readings: Mapping[str, float] | None = None,
) -> tuple[list[Answer], list[tuple[int, Command]]]:
    """One answer per item, in order, and the commands queued (with their answer's index)."""
    answers: list[Answer] = []
    queued: list[tuple[int, Command]] = []
    for item in items:
        if item.kind == ItemKind.COMMAND:
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
        elif item.kind == ItemKind.QUERY:
            answers.append(_answer_query(vessel, item))
        elif item.kind == ItemKind.STATUS:
            answers.append(_answer_status(vessel, item, now, readings))
        elif item.kind == ItemKind.HELP:
            answers.append(language.answer_help(item))
        else:
            answers.append(language.answer_error(item))
    _say_superseded(answers, queued)
    return answers, queued


def _say_superseded(answers: list[Answer], queued: list[tuple[int, Command]]) -> None:
    """Two navigation orders in one SMS: the later one replaced the earlier; say so.

    Known without reading them back: this SMS's commands are not yet committed, so nothing
    but a later navigation order of the same SMS can have moved them (command_enqueue).
    """
    navigation = [(i, c) for i, c in queued if catalog.KINDS[c.kind].navigation]
    for index, command in navigation[:-1]:
        command.status = Status.SUPERSEDED
        answers[index] = replace(answers[index], outcome=command.status.upper())


def _values(command: Command) -> str:
    """A stored command's values as its SMS text gives them (``ON`` for ``#LIGHT ON``)."""
    try:
        text = catalog.to_text(command.kind, command.params)
    except (CatalogError, KeyError, TypeError, ValueError):
        return command.kind
    return text.partition(" ")[2] or text


def _command_text(command: Command) -> str:
    try:
        return catalog.to_text(command.kind, command.params)
    except (CatalogError, KeyError, TypeError, ValueError):
        return command.kind  # a kind with no text form (move_to on a MAVLink boat)


def _answer_query(vessel: Vessel, item: Item) -> Answer:
    """``#LIGHT`` → ``#LIGHT ON``: the newest command of the kind the vessel has (or "unknown"),
    then a newer one still queued (``#LIGHT ON, OFF QUEUED``)."""
    state = selectors.command_state(vessel=vessel, kind=item.command)
    known = state.known
    if known is None:
        outcome = "unknown"
    else:
        outcome = _values(known) + ("" if known.status == "done" else f" ({known.status})")
    queued = state.queued
    if queued is not None and (known is None or queued.created_at >= known.created_at):
        outcome += f", {_values(queued)} QUEUED"
    return Answer(item.echo, outcome)


def _age(seconds: float) -> str:
    seconds = max(0, int(seconds))
    for unit, size, up_to in (("s", 1, 120), ("m", 60, 120 * 60), ("h", 3600, 48 * 3600)):
        if seconds < up_to:
            return f"{seconds // size}{unit}"
    return f"{seconds // 86400}d"


def _answer_status(
    vessel: Vessel, item: Item, now: dt.datetime, readings: Mapping[str, float] | None = None
) -> Answer:
    """Position and its age, battery, navigation mode, pending commands (DESIGN §4), then the
    sensor readings: the live ones when given (the bridge's), else the last fix's."""
    fresh = Vessel.objects.only("last_fix", "last_fix_at", "kind").get(pk=vessel.pk)
    fix = fresh.last_fix or {}
    if isinstance(fix.get("lat"), int | float) and isinstance(fix.get("lon"), int | float):
        age = f" {_age((now - fresh.last_fix_at).total_seconds())} ago" if fresh.last_fix_at else ""
        position = f"pos {fix['lat']:.4f} {fix['lon']:.4f}{age}"
    else:
        position = "pos unknown"
    battery = fresh.battery_v
    battery_text = f"batt {battery:.1f}V" if isinstance(battery, int | float) else "batt unknown"
    navigation = selectors.navigation_current(vessel=vessel)
    nav = f"nav {_command_text(navigation)} {navigation.status}" if navigation else "nav unknown"
    pending = selectors.commands_pending(vessel=vessel)
    sensed = replies.readings_text(readings or fix.get("readings") or {})
    sensed = f", {sensed}" if sensed else ""
    return Answer(item.echo, f"{position}, {battery_text}, {nav}, {pending} pending{sensed}")


# -- outgoing (the modem loop) ----------------------------------------------------------------


def sms_outgoing_pending(*, vessel: Vessel) -> list[SmsMessage]:
    """The vessel's replies waiting for the modem, oldest first."""
    return list(
        SmsMessage.objects.filter(
            vessel=vessel, direction=Direction.OUT, status=SendStatus.PENDING
        ).order_by("created_at", "pk")
    )


def _settle(message: SmsMessage, changes: dict[str, object]) -> bool:
    """Move a pending outgoing SMS on, once: a conditional UPDATE, so a second mark is a no-op."""
    won = (
        SmsMessage.objects.filter(
            pk=message.pk, direction=Direction.OUT, status=SendStatus.PENDING
        ).update(**changes)
        == 1
    )
    if won:
        for name, value in changes.items():
            setattr(message, name, value)
    return won


def sms_mark_sent(
    *, message: SmsMessage, reference: int | str, now: dt.datetime, detail: str = ""
) -> bool:
    """The modem took the SMS (``+CMGS: <reference>``); False if it was not pending.

    ``detail`` says when it is not sure (the text went out and no answer came): such an SMS is
    counted as sent, never sent again, so that nobody gets the same reply twice."""
    return _settle(
        message,
        {
            "status": SendStatus.SENT,
            "reference": str(reference)[:20],
            "sent_at": now,
            "status_detail": detail[:DETAIL_MAX],
        },
    )


def sms_mark_failed(*, message: SmsMessage, reason: str, now: dt.datetime) -> bool:
    """The modem refused the SMS for good (``+CMS ERROR``); False if it was not pending."""
    return _settle(
        message,
        {"status": SendStatus.FAILED, "status_detail": reason[:DETAIL_MAX], "sent_at": None},
    )


def sms_replies_due(*, vessel: Vessel, now: dt.datetime) -> int:
    """Release the vessel's held replies whose time has come; how many were released.

    1. Every command of a waiting reply has ended: it goes out saying what happened
       (``#FHEAD 230 OK``).
    2. Its window has passed first: it goes out as it stands (``QUEUED`` for the commands still
       on their way), and a follow-up naming only the commands waits, with no window, for
       them to end (issue 11 §3: one more SMS when the command ends).

    Each release is a conditional UPDATE from ``waiting``: run twice, or from two threads, it
    releases once.
    """
    released = 0
    waiting = SmsMessage.objects.filter(
        vessel=vessel, direction=Direction.OUT, status=SendStatus.WAITING
    ).order_by("created_at", "pk")
    # A failed command's reason as the bridge recorded it (CommandEvent.cc_reason), read in the
    # same query as the commands.
    cc_reason = (
        CommandEvent.objects.filter(command=OuterRef("pk"), to_status=Status.FAILED)
        .exclude(cc_reason="")
        .order_by("-at", "-pk")
        .values("cc_reason")[:1]
    )
    for reply in waiting:
        records = [r for r in reply.parsed or [] if isinstance(r, dict)]
        pks = [r["command"] for r in records if isinstance(r.get("command"), int)]
        commands = (
            Command.objects.filter(pk__in=pks)
            .annotate(cc_reason=Subquery(cc_reason))
            .values_list("pk", "status", "result_detail", "cc_reason")
        )
        outcomes = {
            pk: replies.command_outcome(status, detail, reason)
            for pk, status, detail, reason in commands
        }
        text, ended = replies.settle(records, outcomes)
        if ended:
            released += _release(reply, text)
        elif reply.due_at is not None and reply.due_at <= now:
            with transaction.atomic():
                if _release(reply, text):
                    released += 1
                    _follow_up(reply, [r for r in records if "command" in r], pks)
    return released


def _release(reply: SmsMessage, text: str) -> int:
    return SmsMessage.objects.filter(pk=reply.pk, status=SendStatus.WAITING).update(
        status=SendStatus.PENDING, text=text
    )


def _follow_up(reply: SmsMessage, records: list[dict], pks: list[int]) -> None:
    later = SmsMessage.objects.create(
        direction=Direction.OUT,
        vessel_id=reply.vessel_id,
        number=reply.number,
        number_e164=reply.number_e164,
        authorised_number_id=reply.authorised_number_id,
        authorised=True,
        text=reply.text,
        parsed=records,
        reply_to_id=reply.reply_to_id,
        status=SendStatus.WAITING,
        status_detail="sent when the commands end",
    )
    later.commands.set(pks)


# -- authorised numbers -----------------------------------------------------------------------


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


# -- the shore link (issue 11 §6): numbers from the shore, the glider's SMS log to it ---------


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
    e164 = _e164_or_blank(number)
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
