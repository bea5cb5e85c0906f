"""The one interface every channel kind implements, and its one error."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol


class TransportError(Exception):
    """A message did not go. ``permanent``: retrying cannot help (a refused address, a 404, a
    number the network rejects); otherwise it may go later (a timeout, a 503, a busy modem)."""

    def __init__(self, message: str, permanent: bool = False) -> None:
        super().__init__(message)
        self.permanent = permanent


@dataclass(frozen=True)
class Message:
    """What one notification (or one flood summary) says, in each channel kind's form.

    ``payload`` is the webhook's JSON body; a summary has none, as webhooks are never
    summarised (their receivers are programs that expect one alert per request).
    """

    event: str
    subject: str  # the e-mail's subject line
    body: str  # the e-mail's plain text
    sms: str  # one SMS: 160 GSM-7 septets at most (messages.fit_sms)
    payload: dict[str, Any] | None = None


class Transport(Protocol):
    """One channel kind. ``send`` raises TransportError only; ``close`` frees what a run of
    sends kept open (the modem's port) and may be called any number of times."""

    def send(self, channel: Any, message: Message) -> None: ...

    def close(self) -> None: ...
