"""Signed webhooks: POST the event's JSON with X-Shoreside-Timestamp and X-Shoreside-Signature.

The body is serialised once and the signature made over exactly those bytes; each attempt is
signed afresh with its own timestamp, so a retry an hour later is not refused as a replay.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from typing import Any

from . import posting, signing
from .base import Message, TransportError


def body_of(payload: dict[str, Any]) -> bytes:
    """The raw body: compact UTF-8 JSON (what the signature covers)."""
    return json.dumps(payload, separators=(",", ":"), ensure_ascii=False).encode()


class WebhookTransport:
    def __init__(self, *, timeout_s: float, clock: Callable[[], float] = time.time) -> None:
        self.timeout_s = timeout_s
        self.clock = clock

    def send(self, channel: Any, message: Message) -> None:
        if message.payload is None:
            raise TransportError("a webhook takes one alert per request", permanent=True)
        if not channel.secret:
            raise TransportError("the channel has no secret to sign with", permanent=True)
        body = body_of(message.payload)
        headers = signing.headers(channel.secret, int(self.clock()), body)
        headers["X-Shoreside-Event"] = message.event
        posting.post(channel.target, body, headers, self.timeout_s)

    def close(self) -> None:
        pass
