"""A shore command to its glider by SMS (docs/links.md, 'Commands by SMS'): one SMS in the
glider's own language with a reference to the command's uid (``sms.command_text``), sent
through the shore's SMS sender (the alerts' modem or gateway, which the caller passes: sms
sits below alerts), logged and counted.

Which link a command takes is not decided here: ``sms_send_command`` is called by whoever
decides (the per-vessel routing), as ``sbd_send_command`` is for Iridium. It does not move the
command on: the glider acks it by uid like an HTTP-polled command, through its shore link.
"""

from __future__ import annotations

import datetime as dt
import logging
from typing import Protocol

from django.db import transaction
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
       Wave Glider or has no SMS number (RouteNotConfigured), the command cannot be said in
       one SMS (NotSayable: a mission, a fence, a long ``#FCOURSE``).
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
    text = render(command.kind, command.params, command.uid)
    return _send(command, text, sender, now or timezone.now())


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
