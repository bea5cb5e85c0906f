"""A shore command to its glider by SMS (docs/links.md, 'Commands by SMS'): one SMS in the
glider's own language with a signed reference to the command's uid (``sms.command_text``),
sent through the shore's SMS sender (the alerts' modem or gateway, which the caller passes: sms
sits below alerts), logged and counted.

The reference is signed with the hash of the vessel key the glider's shore link presents: of
the vessel's active keys, the one used most recently (``VesselKey.last_used_at``; never used:
the newest made). The glider checks it with the key it is configured with, so a key changed on
the glider signs correctly once it has been used (its first poll on the new key).

Which link a command takes is not decided here: ``sms_send_command`` is called by whoever
decides (the per-vessel routing), as ``sbd_send_command`` is for Iridium. It does not move the
command on: the glider acks it by uid like an HTTP-polled command, through its shore link.
"""

from __future__ import annotations

import datetime as dt
import logging
from typing import Protocol

from django.db import transaction
from django.db.models import F
from django.utils import timezone

from commands.models import Command
from edge_client.contract.kinds import WAVE_GLIDER
from links.models import Transport
from links.services import link_count
from sms.command_text import render
from sms.errors import RouteNotConfigured
from sms.gsm7 import on_air
from sms.models import Direction, SendStatus, SmsMessage
from sms.services._common import _save_checked
from sms.services.outgoing import sms_mark_failed, sms_mark_sent
from vessels.models import Vessel, VesselKey

logger = logging.getLogger(__name__)

# The log entry's ``parsed`` names what it carried: the routed command's kind and uid.
ROUTE_KEY = "route"


class SmsSender(Protocol):
    """What sends: alerts.notify.sms's ModemSender or GatewaySender (fleet.relays makes one
    from the settings). ``send_sms`` returns the modem's reference, if it gives one, and
    raises on a text not sent."""

    def send_sms(self, number: str, text: str) -> str | None: ...


def sms_send_command(
    command: Command, *, sender: SmsSender, now: dt.datetime | None = None
) -> SmsMessage:
    """Text ``command`` to its vessel's own number; the outgoing SMS as it ended.

    1. Raises (SmsRouteError, nothing written or sent) when it cannot go: the vessel is not a
       Wave Glider, has no SMS number or no active vessel key to sign the reference with
       (RouteNotConfigured), the command cannot be said in one SMS (NotSayable: a mission, a
       fence, a long ``#FCOURSE``).
    2. The SMS is logged as an outgoing message of the vessel, linked to the command, before
       it is handed over: a crash while sending leaves it *pending*, never unrecorded.
    3. Sent: marked *sent* (with the modem's reference when it gives one) and counted on the
       vessel's SMS link in the same transaction: once, as sent. Refused or not reachable: marked
       *failed* with the reason and logged; nothing raised, nothing counted.

    ``sender`` stays open: the caller closes it (one modem session for a pass's texts).
    """
    vessel = command.vessel
    if vessel.kind != WAVE_GLIDER:
        raise RouteNotConfigured(f"{vessel.name} is not a Wave Glider: it reads no SMS commands")
    if not vessel.sms_number:
        raise RouteNotConfigured(f"{vessel.name} has no SMS number")
    key_hash = signing_key_hash(vessel)
    if key_hash is None:
        raise RouteNotConfigured(
            f"{vessel.name} has no active vessel key: an SMS command's reference is signed "
            "with the key the glider's shore link uses, and the glider refuses one unsigned"
        )
    text = render(command.kind, command.params, command.uid, key_hash)
    return _send(command, text, sender, now or timezone.now())


def signing_key_hash(vessel: Vessel) -> str | None:
    """The hash of the key a referenced SMS to ``vessel`` is signed with: its active key used
    most recently, else its newest active key (see the module docstring); None: no active key.
    A revoked key never signs: the glider may still hold it, but the shore no longer trusts it."""
    return (
        VesselKey.objects.filter(vessel=vessel, revoked_at__isnull=True)
        .order_by(F("last_used_at").desc(nulls_last=True), "-created_at", "-pk")
        .values_list("key_hash", flat=True)
        .first()
    )


def _send(command: Command, text: str, sender: SmsSender, now: dt.datetime) -> SmsMessage:
    vessel = command.vessel
    with transaction.atomic():
        message = _save_checked(
            SmsMessage(
                direction=Direction.OUT,
                vessel=vessel,
                number=vessel.sms_number,
                number_e164=vessel.sms_number,
                text=text,
                authorised=True,
                parsed=[{ROUTE_KEY: "sms", "command": command.kind, "uid": str(command.uid)}],
                status=SendStatus.PENDING,
            )
        )
        message.commands.add(command)
    try:
        reference = sender.send_sms(vessel.sms_number, text)
    # Whatever the sender's way out raised (alerts' TransportError, a modem's error, a
    # socket's): the text was not sent; it is said, never raised.
    except Exception as exc:  # noqa: BLE001
        reason = f"not sent: {exc}"
        logger.warning("command %s to %s by SMS %s", command.uid, vessel.sms_number, reason)
        sms_mark_failed(message=message, reason=reason, now=now)
        return message
    nbytes, segments = on_air(text)
    with transaction.atomic():
        if sms_mark_sent(message=message, reference=reference or "", now=now):
            link_count(vessel_id=vessel.pk, transport=Transport.SMS, at=now,
                       messages_out=1, bytes_out=nbytes, credits=segments)  # fmt: skip
    logger.info("command %s (%s) sent to %s by SMS", command.uid, command.kind, vessel.sms_number)
    return message
