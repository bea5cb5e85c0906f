"""Notifications: owed when an alert event happens, claimed, sent, retried, summarised.

The sender has healthchecks' ``sendalerts`` shape: rows are claimed with a conditional UPDATE
(``pending`` → ``sending``, with the claimer's token), so two ``run_alerts`` side by side never
send the same notification, and sent only after the claim has committed; the slow I/O holds no
transaction and no lock. A claim left ``sending`` longer than CLAIM_TIMEOUT (its worker died
mid-send) may be claimed again. Who gets what: a rule's ``channels`` (a rule is for one vessel
or for the vessels of a kind, so per rule is per vessel too). Docs: docs/alerts.md.
"""

from __future__ import annotations

import datetime as dt
import logging
import secrets
from collections.abc import Callable, Iterable
from itertools import groupby
from typing import Any

from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import transaction
from django.db.models import F, Q
from django.utils import timezone

from alerts.models import (
    Alert,
    ChannelKind,
    Notification,
    NotificationChannel,
    NotificationState,
)
from alerts.notify import Message, Transport, TransportError, transports_from_settings
from alerts.notify import messages as texts
from audit.services import audit_record
from edge_client.contract.backoff import UNTIL_THE_CAP, after_failures

log = logging.getLogger(__name__)

PENDING, SENDING = NotificationState.PENDING, NotificationState.SENDING
SENT, FAILED = NotificationState.SENT, NotificationState.FAILED
# Longer than the slowest send (an SMS through the modem: a minute for +CMGS, plus waking and
# setting the modem up), so a live worker's claim is never taken from under it.
CLAIM_TIMEOUT = dt.timedelta(minutes=5)
SEND_LIMIT = 100  # claimed per channel per pass; a flood beyond it is summarised per pass
# The wait after the first failure, doubled per failure up to the cap: 30 s, 1, 2, 4 … 30 min
# (8 attempts span about an hour, ALERTS_NOTIFY_MAX_ATTEMPTS).
RETRY_FIRST_S = 30.0
RETRY_MAX_S = 30 * 60.0
# Human channels get a flood as one summary; a webhook's receiver is a program that expects
# the documented one-alert body, so it gets every event as it is.
SUMMARISED_KINDS = {ChannelKind.EMAIL, ChannelKind.SMS}
WEBHOOK_SECRET_BYTES = 32  # 256 bits, as long as the HMAC-SHA256 key can use
SECRET_MIN_LENGTH = 16
ERROR_MAX = 1000  # characters of a failure kept in last_error


# -- queue ---------------------------------------------------------------------------------------


def notifications_queue(*, alert: Alert, event: str, now: dt.datetime | None = None) -> int:
    """Owe one notification of ``event`` about ``alert`` to each active channel of its rule.

    Runs in the caller's transaction (the evaluator's alert_open/…): an event rolled back
    leaves nothing owed. Returns how many were queued.
    """
    if event not in texts.EVENTS:
        raise ValueError(f"{event!r} is not one of {', '.join(texts.EVENTS)}")
    now = now or timezone.now()
    # .all() and a filter in Python, not .filter(active=True): the evaluator prefetches each
    # rule's channels, and a query per alert is most of a busy pass's writes (bench.alerts).
    rows = [
        Notification(alert=alert, channel=channel, event=event, created_at=now, due_at=now)
        for channel in alert.rule.channels.all()
        if channel.active
    ]
    for row in rows:
        row.full_clean(exclude=["alert", "channel", "summarised_in"])  # FKs: just fetched
    Notification.objects.bulk_create(rows)
    return len(rows)


# -- send ----------------------------------------------------------------------------------------


def notifications_send_due(*, now: dt.datetime | None = None, worker: str,
                           limit: int = SEND_LIMIT,
                           stop: Callable[[], bool] | None = None) -> int:  # fmt: skip
    """Claim the notifications due at ``now`` and send them; return how many were delivered
    (each one a summary carried counts). Call it outside any transaction.

    1. Claim up to ``limit`` due rows per channel (pending and due, or sending with a stale
       claim) in one conditional UPDATE that stamps this pass's token and counts the attempt;
       keep the rows that carry the token (a racing worker's UPDATE matches none of them).
    2. Group them by channel and event. A group of more than ALERTS_NOTIFY_FLOOD on an e-mail
       or SMS channel is one summary, carried by its oldest row; the others are summarised_in it.
    3. Send each message after the claim committed; settle each row with a conditional UPDATE
       on its token: sent; or on a temporary failure pending again at a backoff (failed after
       ALERTS_NOTIFY_MAX_ATTEMPTS); or failed on a permanent one. A failing channel is logged
       and the pass goes on with the next.
    4. Once ``stop()`` says so (run_alerts told to stop), the rows not sent yet are handed
       back, pending and due as they were, for the next sender: a channel that hangs (a dead
       host, up to ALERTS_HTTP_TIMEOUT_S a try) never holds a stop for the whole batch.
    """
    now = now or timezone.now()
    token = f"{worker[:50]}/{secrets.token_hex(4)}"
    claimed = _claim(now=now, token=token, limit=limit)
    if not claimed:
        return 0
    transports = transports_from_settings()
    delivered = 0
    try:
        for rows in _batches(claimed):
            if stop is not None and stop():
                _hand_back(token)
                break
            delivered += _deliver(rows, transports, token=token, now=now)
    finally:
        for transport in transports.values():
            transport.close()
    return delivered


def _hand_back(token: str) -> None:
    """Rows this pass claimed but did not send: pending again, their attempt not counted."""
    Notification.objects.filter(state=SENDING, claimed_by=token).update(
        state=PENDING, claimed_by="", claimed_at=None, attempts=F("attempts") - 1
    )


def _claim(*, now: dt.datetime, token: str, limit: int) -> list[Notification]:
    # The partial index notification_due covers the scan (state pending/sending, due_at).
    due = Q(state__in=[PENDING, SENDING], due_at__lte=now) & (
        Q(state=PENDING) | Q(claimed_at__lt=now - CLAIM_TIMEOUT)
    )
    # Up to ``limit`` per channel, oldest first: one channel's backlog (a flood, a loop that
    # stopped before sending) must not hold up the others pass after pass, as it did when the
    # pass took the oldest ``limit`` of all (a fence crossing's webhook waited over 30 s behind
    # e-mail owed, bench.alerts). A query per channel with something due: a handful.
    owed = Notification.objects.filter(due)
    channels = owed.order_by("channel_id").values_list("channel_id", flat=True).distinct()
    rows = []
    for channel_id in channels:
        rows += (
            owed.filter(channel_id=channel_id)
            .order_by("due_at", "pk")
            .values_list("pk", "state", "attempts")[:limit]
        )
    # A stale claim that has had all its attempts: its sender died in the middle each time
    # (a send that kills the process?); taking it again would only repeat that for ever.
    spent = [pk for pk, state, tries in rows if state == SENDING and tries >= _max_attempts()]
    if spent:
        log.error("notifications %s: their senders never came back; given up", spent)
        Notification.objects.filter(due, pk__in=spent).update(
            state=FAILED, last_error="given up: the sender never came back from sending it"
        )
    candidates = [pk for pk, _state, _tries in rows if pk not in spent]
    if not candidates:
        return []
    # Races with another worker's identical UPDATE: whichever commits first takes a row; the
    # other's WHERE no longer matches it (PostgreSQL re-checks it after the row lock; SQLite
    # runs one writer at a time).
    Notification.objects.filter(due, pk__in=candidates).update(
        state=SENDING, claimed_by=token, claimed_at=now, attempts=F("attempts") + 1
    )
    return list(
        Notification.objects.filter(pk__in=candidates, state=SENDING, claimed_by=token)
        .select_related("alert__vessel", "alert__rule", "channel")
        .order_by("channel_id", "event", "created_at", "pk")
    )


def _batches(claimed: list[Notification]) -> Iterable[list[Notification]]:
    """One list per message to send: a flood on a human channel as one, the rest one each."""
    flood = settings.ALERTS_NOTIFY_FLOOD
    for _key, group in groupby(claimed, key=lambda n: (n.channel_id, n.event)):
        rows = list(group)
        if flood and len(rows) > flood and rows[0].channel.kind in SUMMARISED_KINDS:
            yield rows
        else:
            yield from ([row] for row in rows)


def _deliver(rows: list[Notification], transports: dict[str, Any], *, token: str,
             now: dt.datetime) -> int:  # fmt: skip
    carrier, channel = rows[0], rows[0].channel
    if not channel.active:
        _settle(rows, token, state=FAILED, last_error="the channel was turned off")
        return 0
    event = carrier.event
    transport: Transport | None = transports.get(channel.kind)
    try:
        if transport is None:
            raise TransportError(f"no transport for {channel.kind!r} channels", permanent=True)
        message: Message = (
            texts.single(event, carrier.alert)
            if len(rows) == 1
            else texts.summary(event, [row.alert for row in rows])
        )
        transport.send(channel, message)
    except TransportError as exc:
        for row in rows:
            _failed(row, token, now=now, error=str(exc), permanent=exc.permanent, channel=channel)
        return 0
    except Exception as exc:  # noqa: BLE001 - one broken channel must not stop the others
        log.exception("notification %s on %s: unexpected error", carrier.pk, channel)
        for row in rows:
            _failed(row, token, now=now, error=repr(exc), permanent=False, channel=channel)
        return 0
    done = _settle([carrier], token, state=SENT, sent_at=now, last_error="")
    if len(rows) > 1:  # one UPDATE for the flood it carried
        done += _settle(rows[1:], token, state=SENT, sent_at=now, last_error="",
                        summarised_in=carrier)  # fmt: skip
    what = f"summary of {len(rows)}" if len(rows) > 1 else f"alert {carrier.alert_id}"
    log.info("%s sent to %s (%s)", event, channel, what)
    return done


def _max_attempts() -> int:
    return settings.ALERTS_NOTIFY_MAX_ATTEMPTS


def _failed(row: Notification, token: str, *, now: dt.datetime, error: str, permanent: bool,
            channel: NotificationChannel) -> None:  # fmt: skip
    if permanent or row.attempts >= _max_attempts():
        why = error if permanent else f"gave up after {row.attempts} attempts: {error}"
        log.error("notification %s to %s failed: %s", row.pk, channel, why)
        _settle([row], token, state=FAILED, last_error=why[:ERROR_MAX])
        return
    wait = after_failures(RETRY_FIRST_S, row.attempts - 1, cap=RETRY_MAX_S,
                          max_doublings=UNTIL_THE_CAP)  # fmt: skip
    log.warning("notification %s to %s not sent (%s); again in %.0f s", row.pk, channel, error,
                wait)  # fmt: skip
    _settle([row], token, state=PENDING, due_at=now + dt.timedelta(seconds=wait),
            claimed_by="", claimed_at=None, last_error=error[:ERROR_MAX])  # fmt: skip


def _settle(rows: list[Notification], token: str, **changes: Any) -> int:
    """Write the outcome to the rows still claimed by this pass; return how many. Fewer when a
    stale-claim takeover got some first (this pass outlived CLAIM_TIMEOUT): theirs stands."""
    pks = [row.pk for row in rows]
    won = Notification.objects.filter(pk__in=pks, state=SENDING, claimed_by=token).update(**changes)
    if won < len(rows):
        log.warning("%d of notifications %s were reclaimed meanwhile", len(rows) - won, pks)
    return won


# -- channels ------------------------------------------------------------------------------------


@transaction.atomic
def notification_channel_create(*, name: str, kind: str, target: str, secret: str | None = None,
                                by: Any, via: str = "", ip: str | None = None,
                                ) -> tuple[NotificationChannel, str]:  # fmt: skip
    """Make a channel; return it with its webhook secret ("" for other kinds), shown this once.

    The target is checked per kind (an e-mail address, a phone number kept in E.164, an
    http(s) URL). A webhook gets ``secret`` when given (at least 16 characters), else a new
    random one. ``by`` is the operator (a user or a user name); the audit log says who made it.
    """
    if kind != ChannelKind.WEBHOOK and secret:
        raise ValidationError({"secret": "Only a webhook has a secret."})
    if kind == ChannelKind.WEBHOOK:
        secret = secret if secret is not None else secrets.token_hex(WEBHOOK_SECRET_BYTES)
        if len(secret) < SECRET_MIN_LENGTH:
            raise ValidationError({"secret": f"At least {SECRET_MIN_LENGTH} characters."})
    channel = NotificationChannel(name=name, kind=kind, target=target, secret=secret or "")
    channel.full_clean()
    channel.save()
    audit_record(
        action="channel.created",
        actor=_username(by),
        via=via,
        ip=ip,
        subject_type="notification_channel",
        subject_id=channel.pk,
        subject=channel,
        detail={"kind": channel.kind, "target": channel.target},  # never the secret
    )
    return channel, channel.secret


def _username(by: Any) -> str:
    get = getattr(by, "get_username", None)
    return get() if callable(get) else str(by or "")
