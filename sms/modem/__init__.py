"""GSM modem: the SMS AT dialogue in text mode, a driver and a simulator. No Django here.

Protocol facts and quirks: docs/sms.md, 'The GSM modem'. Layers: ``at``
(line reader, parsers, error codes) and ``errors`` are pure; ``driver`` is the only module that
opens ports (pyserial ``serial_for_url``); ``simulator`` is a modem for tests and demos (pty or
TCP); ``cli`` is ``python -m sms.modem``.

The API the SMS service plugs into: :class:`Modem` (``open``, ``poll_events``,
``stored_messages``, ``read``, ``delete``, ``send``), :func:`receive_all` (read → store →
delete, in that order) and :class:`ReceivedSms` (``key`` = number, text, modem timestamp).
"""

from __future__ import annotations

from .at import ReceivedSms
from .driver import Modem, ModemConfig, ModemEvents, receive_all
from .errors import (
    CommandError,
    ModemError,
    ModemRestarted,
    ModemTimeout,
    PinRequired,
    PortError,
    SendUnconfirmed,
    UnsendableText,
)

__all__ = [
    "CommandError",
    "Modem",
    "ModemConfig",
    "ModemError",
    "ModemEvents",
    "ModemRestarted",
    "ModemTimeout",
    "PinRequired",
    "PortError",
    "ReceivedSms",
    "SendUnconfirmed",
    "UnsendableText",
    "receive_all",
]
