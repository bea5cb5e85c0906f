"""The payload machine as the bridge runs it: it tells its command source which request it is
answering, and keeps the last power notice frame for the log.

References (docs/level2.md, its § table): §8.5 (request queued), §8.8 (power notices), §10 (a
retry repeats the tid). ``CommandSource.take_next()`` takes no arguments, but a crash-safe
source must know the request's tid to answer a retry after a restart identically
(``sms.bridge.commands``); this subclass hands it over before the machine runs. Pure: no I/O.
"""

from __future__ import annotations

from typing import Protocol

from sms.level2.codec import Frame, MessageType
from sms.level2.payload import CommandSource, PayloadConfig, PayloadMachine, SensorState


class RequestAwareSource(CommandSource, Protocol):
    def note_request(self, frame: Frame) -> None:
        """The frame about to be handled."""
        ...


class BridgeMachine(PayloadMachine):
    """A :class:`PayloadMachine` whose source sees each request before it is handled."""

    def __init__(
        self,
        config: PayloadConfig | None = None,
        *,
        source: RequestAwareSource,
        sensors: SensorState | None = None,
    ) -> None:
        super().__init__(config, source=source, sensors=sensors)
        self.request_aware_source = source
        self.last_power_frame: Frame | None = None

    def handle(self, frame: Frame) -> list[Frame]:
        self.request_aware_source.note_request(frame)
        if frame.msg_type == MessageType.POWER:
            self.last_power_frame = frame
        return super().handle(frame)
