"""SMS: one interface, two ways out. The shore server's own GSM modem (``sms.modem``'s driver,
ALERTS_SMS_MODEM_URL) or an HTTP SMS gateway (ALERTS_SMS_GATEWAY_URL, a JSON POST with a token).

Texts arrive fitted to one SMS (``messages.fit_sms``: GSM-7, 160 septets), the only kind the
driver sends in text mode. The modem is opened on the first SMS of a sending pass and closed at
its end (``close``), with an exclusive lock on a serial device so that two ``run_alerts`` side
by side take turns rather than talk over each other on one port.
"""

from __future__ import annotations

import json
import logging
from typing import Any, Protocol

import serial

from sms.modem import Modem, ModemConfig, ModemError, PinRequired, SendUnconfirmed
from sms.modem.driver import BAUDRATE, READ_TIMEOUT_S

from . import posting
from .base import Message, TransportError

log = logging.getLogger(__name__)


class SmsSender(Protocol):
    """``send_sms`` raises TransportError only; it returns the modem's reference for the SMS
    when there is one (the shore's command route logs it), else None."""

    def send_sms(self, number: str, text: str) -> str | None: ...

    def close(self) -> None: ...


def open_exclusive(url: str, baudrate: int = BAUDRATE) -> Any:
    """The driver's port, locked (flock) when it is a device: a second opener waits its turn."""
    return serial.serial_for_url(url, baudrate=baudrate, timeout=READ_TIMEOUT_S, exclusive=True)


class ModemSender:
    """Through the shore's own GSM modem. Incoming texts are left on the SIM: this sends only."""

    def __init__(self, config: ModemConfig | str) -> None:
        self.config = ModemConfig(config) if isinstance(config, str) else config
        self._modem: Modem | None = None

    def send_sms(self, number: str, text: str) -> str | None:
        if self._modem is None:
            self._modem = Modem(self.config, port_factory=open_exclusive)
        try:
            reference = self._modem.send(number, text)
        except SendUnconfirmed as exc:
            # The text and Ctrl-Z went out: it has probably gone, and sending it again could
            # wake someone twice (as sms.bridge.sms_link does with replies). Counted as sent.
            log.warning("SMS to %s went out unconfirmed: %s", number, exc)
            return None
        except PinRequired as exc:
            raise TransportError(f"modem: {exc}") from None  # the SIM's trouble, not the text's
        except ModemError as exc:
            raise TransportError(f"modem: {exc}", permanent=exc.permanent) from None
        log.info("SMS to %s sent by the modem (ref %s)", number, reference)
        return str(reference)

    def close(self) -> None:
        modem, self._modem = self._modem, None
        if modem is not None:
            modem.close()


class GatewaySender:
    """An HTTP SMS gateway: ``POST <url>`` with ``Authorization: Bearer <token>`` and the JSON
    body ``{"to": "+61412345678", "text": "…"}``; any 2xx is taken as accepted."""

    def __init__(self, url: str, token: str, *, timeout_s: float) -> None:
        self.url, self.token, self.timeout_s = url, token, timeout_s

    def send_sms(self, number: str, text: str) -> str | None:
        body = json.dumps({"to": number, "text": text}, ensure_ascii=False).encode()
        headers = {"Authorization": f"Bearer {self.token}"} if self.token else {}
        posting.post(self.url, body, headers, self.timeout_s)
        return None

    def close(self) -> None:
        pass


class SmsTransport:
    def __init__(self, sender: SmsSender | None) -> None:
        self.sender = sender

    def send(self, channel: Any, message: Message) -> None:
        if self.sender is None:
            raise TransportError(
                "SMS is not configured: set ALERTS_SMS_MODEM_URL or ALERTS_SMS_GATEWAY_URL",
                permanent=True,
            )
        self.sender.send_sms(channel.target, message.sms)

    def close(self) -> None:
        if self.sender is not None:
            self.sender.close()
