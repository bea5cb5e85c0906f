"""Notification transports: e-mail, signed webhooks and SMS, behind one small interface.

The shape is healthchecks' ``Transport``: ``send(channel, message) -> None`` raising
:class:`TransportError` with ``permanent`` saying whether a retry can help. Nothing above
this package knows how a message travels; ``alerts.services.notifications`` claims the work,
retries and summarises. Settings and the webhook's signature: docs/alerts.md.

* :mod:`.base` the interface, the error and :class:`Message`;
* :mod:`.messages` (pure) what an alert event says on each kind of channel, one SMS long;
* :mod:`.signing` (pure) the webhook signature, and how a receiver checks it;
* :mod:`.targets` a channel's target checked and normalised per kind;
* :mod:`.mail`, :mod:`.webhook`, :mod:`.sms` (modem or HTTP gateway), :mod:`.posting`: the I/O;
* :mod:`.registry` the transports the settings ask for.
"""

from __future__ import annotations

from .base import Message, Transport, TransportError
from .registry import transports_from_settings

__all__ = ["Message", "Transport", "TransportError", "transports_from_settings"]
