"""The ways out the router (fleet.routing) sends by: each a ``Sender`` made from the settings,
or None when the site has no such link configured."""

from __future__ import annotations

import datetime as dt

from commands.models import Command
from fleet.routing import Refused, Route, Sender
from sbd.errors import SbdError
from sbd.models import Status as SbdStatus
from sbd.rockblock import credits
from sbd.services import sbd_send_command
from sbd.transport import configured_transport


def sbd_sender() -> Sender | None:
    """RockBLOCK's MT API, when SBD_ROCKBLOCK_USERNAME is set."""
    transport = configured_transport()
    if transport is None:
        return None

    def send(command: Command, now: dt.datetime) -> str:
        try:
            message = sbd_send_command(command, transport=transport, now=now)
        except SbdError as exc:
            raise Refused(str(exc)) from None
        n = credits(message.bytes)
        size = f"{message.bytes} bytes, {n} credit{'' if n == 1 else 's'}"
        if message.status == SbdStatus.FAILED:
            raise Refused(f"RockBLOCK refused it: {message.detail}")
        if message.status == SbdStatus.QUEUED:
            # A temporary failure: sbd_send_queued tries again on the next pass.
            return (
                f"queued for Iridium SBD ({size}); RockBLOCK did not take it yet: {message.detail}"
            )
        return f"sent by Iridium SBD ({size}), RockBLOCK message {message.provider_ref}"

    return send


def configured_senders() -> dict[Route, Sender]:
    """Every way out this site has configured."""
    senders: dict[Route, Sender] = {}
    sbd = sbd_sender()
    if sbd is not None:
        senders[Route.SBD] = sbd
    return senders
