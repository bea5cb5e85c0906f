"""When and what the bridge replies to an SMS: the answers, the reply stored for the modem (held
while its commands run, with a reply window), the rate-limit notice, and the release of held
replies (:func:`sms_replies_due`). The texts themselves are composed by :mod:`sms.replies`."""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

from django.conf import settings
from django.db import IntegrityError, transaction
from django.db.models import OuterRef, Subquery

from commands import catalog
from commands.errors import CatalogError
from commands.lifecycle import Status
from commands.models import Command, CommandEvent
from edge_client.contract.status import UNFINISHED
from sms import language, replies, selectors
from sms.language import Answer, Item, ItemKind
from sms.models import AuthorisedNumber, Direction, SendStatus, SmsMessage
from sms.services._common import _save_checked
from vessels.models import Vessel


def reply_store(
    *,
    message: SmsMessage,
    entry: AuthorisedNumber,
    answers: Sequence[Answer],
    queued: Sequence[tuple[int, Command]],
    send_replies: bool,
    reply_window_s: float,
) -> SmsMessage:
    """The one reply to an answered SMS, stored for the modem: pending, or (``send_replies``
    False, for ``sms_inject``) not to be sent. With a ``reply_window_s`` (the bridge's) and a
    command still open, it is held as ``waiting`` until :func:`sms_replies_due` releases it."""
    commands = [command for _, command in queued]
    by_answer = {index: command.pk for index, command in queued}
    status = SendStatus.PENDING if send_replies else SendStatus.NOT_SENT
    hold = send_replies and reply_window_s > 0 and any(c.status in UNFINISHED for c in commands)
    received_at = message.received_at
    reply = _to_sender(
        message,
        entry,
        text=language.compose_reply(answers),
        parsed=[replies.answer_record(a, by_answer.get(i)) for i, a in enumerate(answers)],
        reply_to=message,
        status=SendStatus.WAITING if hold else status,
        status_detail="" if send_replies else "shown by sms_inject, not sent",
        due_at=received_at + dt.timedelta(seconds=reply_window_s) if hold else None,
    )
    return _save_checked(reply)


def _to_sender(message: SmsMessage, entry: AuthorisedNumber, **fields: Any) -> SmsMessage:
    """An outgoing SMS (not yet saved) to the authorised sender of ``message``: a reply, or
    the rate limit's notice."""
    return SmsMessage(
        direction=Direction.OUT,
        vessel=message.vessel,
        number=message.number_e164,
        number_e164=message.number_e164,
        authorised_number=entry,
        authorised=True,
        **fields,
    )


def answer_item(
    vessel: Vessel, item: Item, now: dt.datetime, readings: Mapping[str, float] | None = None
) -> Answer:
    """The answer to an item that queues nothing: a query, ``#STATUS``, help, or an error."""
    if item.kind == ItemKind.QUERY:
        return _answer_query(vessel, item)
    if item.kind == ItemKind.STATUS:
        return _answer_status(vessel, item, now, readings)
    if item.kind == ItemKind.HELP:
        return language.answer_help(item)
    return language.answer_error(item)


def rate_notice(
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
    if SmsMessage.objects.filter(delivery_key=key).exists():
        return None  # told already
    text = replies.rate_limit_notice(
        limit=settings.SMS_RATE_LIMIT,
        window_s=settings.SMS_RATE_WINDOW_S,
        until=until,
        now=message.received_at or until,
    )
    try:
        with transaction.atomic():
            notice = _to_sender(
                message,
                entry,
                text=text,
                reply_to=message,
                delivery_key=key,
                status=SendStatus.PENDING if send_replies else SendStatus.NOT_SENT,
                status_detail="rate limit notice"
                if send_replies
                else "rate limit notice shown by sms_inject, not sent",
            )
            return _save_checked(notice)
    except IntegrityError:
        return None  # a concurrent text of the same number sent it


def say_superseded(answers: list[Answer], queued: list[tuple[int, Command]]) -> None:
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
        outcome = _values(known) + ("" if known.status == Status.DONE else f" ({known.status})")
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
    """Position and its age, battery, navigation mode, pending commands (docs/sms.md), then the
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
    later = SmsMessage(
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
    _save_checked(later)
    later.commands.set(pks)
