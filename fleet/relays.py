"""The ways out the router (fleet.routing) sends by: each a ``Sender`` made from the settings,
or None when the site has no such link configured."""

from __future__ import annotations

import datetime as dt

from alerts.notify.registry import sms_sender_from_settings
from commands.models import Command
from fleet.routing import Refused, Route, Sender, Sent
from sbd.errors import SbdError
from sbd.models import Status as SbdStatus
from sbd.rockblock import credits
from sbd.services import sbd_send_command
from sbd.transport import configured_transport
from sms.errors import SmsRouteError
from sms.gsm7 import on_air
from sms.models import SendStatus
from sms.services import sms_send_command


def sbd_sender() -> Sender | None:
    """RockBLOCK's MT API, when SBD_ROCKBLOCK_USERNAME is set."""
    transport = configured_transport()
    if transport is None:
        return None

    def send(command: Command, now: dt.datetime) -> Sent:
        try:
            message = sbd_send_command(command, transport=transport, now=now)
        except SbdError as exc:
            raise Refused(str(exc)) from None
        n = credits(message.bytes)
        size = f"{message.bytes} bytes, {n} credit{'' if n == 1 else 's'}"
        if message.status == SbdStatus.FAILED:
            raise Refused(f"RockBLOCK refused it: {message.detail}")
        if message.status == SbdStatus.QUEUED:
            # A temporary failure: sbd_send_queued tries again, backing off, while the
            # command stays queued (its history says if it gives up).
            return Sent(
                f"queued for Iridium SBD ({size}); RockBLOCK did not take it yet: {message.detail}",
                n,
            )
        return Sent(f"sent by Iridium SBD ({size}), RockBLOCK message {message.provider_ref}", n)

    return send


def sms_sender() -> Sender | None:
    """The shore's SMS modem or gateway, the one alerts text through (ALERTS_SMS_MODEM_URL or
    ALERTS_SMS_GATEWAY_URL). A modem is opened for one text and closed after it: run_alerts
    may want the same port. While run_alerts holds it the open fails at once (the port's lock
    does not wait): a failure for now, tried again next pass."""
    if sms_sender_from_settings() is None:
        return None

    def send(command: Command, now: dt.datetime) -> Sent:
        sender = sms_sender_from_settings()
        if sender is None:  # the settings changed under a running loop
            raise Refused("the shore has no SMS sender any more")
        try:
            message = sms_send_command(command, sender=sender, now=now)
        except SmsRouteError as exc:
            raise Refused(str(exc)) from None  # it cannot be said, or the vessel has no phone
        finally:
            sender.close()
        if message.status != SendStatus.SENT:
            # The gateway or the modem failed (down, busy, refused): worth another pass.
            raise Refused(
                f"the SMS to {message.number} failed: {message.status_detail}", temporary=True
            )
        return Sent(f"sent by SMS to {message.number}: {message.text}", on_air(message.text)[1])

    return send


def configured_senders() -> dict[Route, Sender]:
    """Every way out this site has configured."""
    senders: dict[Route, Sender] = {}
    for route, make in ((Route.SBD, sbd_sender), (Route.SMS, sms_sender)):
        sender = make()
        if sender is not None:
            senders[route] = sender
    return senders
