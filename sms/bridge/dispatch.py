"""The payload machine's notifications, routed to the bridge's building blocks.

References: ``sms.level2.payload`` (the notifications), docs/level2.md (its § table): §8.1
(enumerate: a restarted C&C), §8.3 (fixes), §8.6 (results), §8.8 (power notices).

A :class:`Dispatcher` is the ``on_notification`` callback of ``sms.level2.runner.PayloadRunner``:
it runs in the runner's thread after the replies are written, so nothing here delays a Level 2
reply. It never raises: a failing handler is logged and the runner keeps serving.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence

from sms.level2.payload import (
    CommandCompleted,
    CommandHandedOver,
    Enumerated,
    FixReceived,
    Ignored,
    Notification,
    PowerDown,
    PowerNotice,
    ResultWithoutCommand,
)

from .commands import DatabaseCommandSource
from .fixes import FixRecorder
from .machine import BridgeMachine
from .power import COMMAND_TIMEOUT_S, PowerDownOutcome, handle_power_down

log = logging.getLogger(__name__)

# §8.8: nobody knows how often the C&C repeats a power notice; one run of the power command per
# this many seconds (a repeat is logged with its frame, not run again).
POWER_DOWN_REPEAT_S = 60.0


class Dispatcher:
    """Route each notification: fixes to the recorder, unmatched results and re-enumerations to
    the command source, power-down notices to :func:`handle_power_down`, the rest to the log."""

    def __init__(
        self,
        *,
        machine: BridgeMachine,
        source: DatabaseCommandSource,
        fixes: FixRecorder,
        power_command: Sequence[str] | None = None,
        power_timeout_s: float = COMMAND_TIMEOUT_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.machine = machine
        self.source = source
        self.fixes = fixes
        self.power_command = power_command
        self.power_timeout_s = power_timeout_s
        self.clock = clock
        self.power_downs: list[PowerDownOutcome] = []
        self._last_power_down: float | None = None
        self.errors = 0

    def __call__(self, note: Notification) -> None:
        try:
            self._route(note)
        except Exception:  # noqa: BLE001 - the Level 2 link must outlive any one handler
            self.errors += 1
            log.exception("handling %r failed", note)

    def _route(self, note: Notification) -> None:
        if isinstance(note, FixReceived):
            self.fixes.record(note.fix)
        elif isinstance(note, ResultWithoutCommand):
            self.source.result_without_command(note.code)
        elif isinstance(note, Enumerated):
            log.info("enumerated by the C&C at %s", note.cc)
            self.source.forget_request_ids()
        elif isinstance(note, CommandHandedOver):
            log.info("command %s (%s) handed over, tid 0x%04X", note.ident, note.text, note.tid)
        elif isinstance(note, CommandCompleted):
            log.info("C&C answered %s: %s", note.result.ident, note.result.meaning)
        elif isinstance(note, PowerDown):
            self._power_down(note)
        elif isinstance(note, PowerNotice):
            log.info("power notice from the C&C: %s", note.body.hex(" "))
        elif isinstance(note, Ignored):
            log.debug("ignored %s: %s", note.frame, note.reason)

    def _power_down(self, note: PowerDown) -> None:
        frame = self.machine.last_power_frame
        raw = bytes(frame) if frame is not None and frame.body == note.body else note.body
        now = self.clock()
        if self._last_power_down is not None and now - self._last_power_down < POWER_DOWN_REPEAT_S:
            log.warning("power-down notice repeated, not acted on again: %s", raw.hex(" "))
            return
        self._last_power_down = now
        self.power_downs.append(
            handle_power_down(
                raw,
                command=self.power_command,
                # Results are written as they come; flush_results writes any the database
                # refused. Fixes wait in a batch.
                flush=[("fixes", self.fixes.flush), ("command results", self.source.flush_results)],
                timeout_s=self.power_timeout_s,
            )
        )
