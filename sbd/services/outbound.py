"""Commands out to an SBD vessel: encoded in the compact command form, queued as outbound
SbdMessage rows (counted: bytes, attempts), handed to the provider's MT API.

Which link a command takes is not decided here: ``sbd_send_command`` is called by whoever
decides (the per-vessel routing, issue 20 §4). A message handed to the provider is "sent";
that the modem fetched it is known only when the boat acknowledges the command (by its uid).
"""

from __future__ import annotations

import datetime as dt
import logging

from django.conf import settings
from django.db import transaction
from django.utils import timezone

from commands.lifecycle import Status as CommandStatus
from commands.models import Command
from commands.services import command_note
from edge_client.contract import compact_command
from links.models import Transport
from links.services import link_count
from sbd.errors import MtError, SbdError
from sbd.models import Direction, SbdMessage, Status
from sbd.rockblock import credits
from sbd.transport import MtTransport, configured_transport

logger = logging.getLogger(__name__)
DETAIL_MAX = 200
RETRY_BASE_S = 30


def sbd_queue_command(*, command: Command, now: dt.datetime | None = None) -> SbdMessage:
    """An outbound message carrying ``command`` in the compact form, queued; SbdError if
    the vessel has no IMEI or the command has no compact form within 270 bytes."""
    vessel = command.vessel
    if not vessel.imei:
        raise SbdError(f"{vessel.name} has no Iridium IMEI")
    try:
        payload = compact_command.encode(command.uid, command.kind, command.params)
    except compact_command.CompactCommandError as exc:
        raise SbdError(f"{command.kind} cannot go by SBD: {exc}") from None
    return SbdMessage.objects.create(
        direction=Direction.OUT,
        vessel=vessel,
        imei=vessel.imei,
        received_at=now or timezone.now(),
        payload=payload,
        bytes=len(payload),
        status=Status.QUEUED,
        command=command,
    )


def _command_moved_on(message: SbdMessage) -> str | None:
    """Why ``message`` must not go any more: its command is no longer queued (cancelled,
    expired, superseded, or the boat took it over HTTP), or None."""
    if message.command_id is None:
        return None
    command = Command.objects.only("status").get(pk=message.command_id)
    return None if command.status == CommandStatus.QUEUED else command.status


def retry_due(message: SbdMessage, now: dt.datetime) -> bool:
    """Whether a queued message's next try is due: at once, then RETRY_BASE_S, 2x, 4x… after
    it was queued in all (30 s, 90 s, 210 s, 450 s): a provider that is down is not hammered
    every pass, and SBD_MT_MAX_ATTEMPTS tries span minutes, not one minute."""
    wait = RETRY_BASE_S * ((1 << message.attempts) - 1)
    return now >= message.received_at + dt.timedelta(seconds=wait)


def _send_one(message: SbdMessage, transport: MtTransport, now: dt.datetime) -> bool:
    """Try ``message`` once; True if the provider took it. The attempt is claimed with a
    conditional update, so two senders never hand the same try over twice."""
    moved_on = _command_moved_on(message)
    if moved_on is not None:
        detail = f"not sent: the command is {moved_on} now"
        SbdMessage.objects.filter(pk=message.pk, status=Status.QUEUED).update(
            status=Status.FAILED, detail=detail
        )
        message.status, message.detail = Status.FAILED, detail
        return False
    tries = message.attempts
    claimed = SbdMessage.objects.filter(pk=message.pk, status=Status.QUEUED, attempts=tries).update(
        attempts=tries + 1
    )
    if not claimed:
        return False
    message.attempts = tries + 1
    try:
        ref = transport.send(message.imei, bytes(message.payload))
    except MtError as exc:
        final = exc.permanent or message.attempts >= settings.SBD_MT_MAX_ATTEMPTS
        message.status = Status.FAILED if final else Status.QUEUED
        message.detail = exc.message[:DETAIL_MAX]
        logger.warning("SBD MT %s to %s: %s", message.pk, message.imei, exc.message)
        SbdMessage.objects.filter(pk=message.pk).update(
            status=message.status, detail=message.detail
        )
        if final and message.command_id is not None:
            command_note(
                command=Command.objects.get(pk=message.command_id),
                actor="shore",
                now=now,
                detail=f"Iridium SBD gave up after {message.attempts} tries: {message.detail}",
            )
        return False
    message.status, message.provider_ref, message.sent_at = Status.SENT, ref[:40], now
    message.detail = ""
    # Paid once the provider takes it (a queued or failed message costs nothing): counted
    # with the write that says so.
    with transaction.atomic():
        SbdMessage.objects.filter(pk=message.pk).update(
            status=Status.SENT, provider_ref=message.provider_ref, sent_at=now, detail=""
        )
        link_count(
            vessel_id=message.vessel_id,
            transport=Transport.SBD,
            at=now,
            messages_out=1,
            bytes_out=message.bytes,
            credits=credits(message.bytes),
        )
    return True


def sbd_send_queued(
    *, transport: MtTransport | None = None, now: dt.datetime | None = None, limit: int = 100
) -> int:
    """One pass over the queue, oldest first; how many the provider took. Nothing is tried
    when no MT transport is configured."""
    transport = transport or configured_transport()
    if transport is None:
        return 0
    now = now or timezone.now()
    queued = SbdMessage.objects.filter(direction=Direction.OUT, status=Status.QUEUED)
    due = [m for m in queued.order_by("received_at")[:limit] if retry_due(m, now)]
    return sum(_send_one(message, transport, now) for message in due)


def sbd_send_command(
    command: Command, *, transport: MtTransport | None = None, now: dt.datetime | None = None
) -> SbdMessage:
    """Queue ``command`` for its vessel's modem and try to send it at once (when an MT
    transport is configured); the message as it stands. SbdError if it cannot go by SBD."""
    now = now or timezone.now()
    message = sbd_queue_command(command=command, now=now)
    transport = transport or configured_transport()
    if transport is not None:
        _send_one(message, transport, now)
    return message
