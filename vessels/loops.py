"""The shape of the site's long-running management commands (healthchecks' ``sendalerts``):
``expire_commands --loop``, ``rebuild_track_overview --loop`` and ``run_alerts``.

SIGTERM and SIGINT only set a flag; the idle wait between passes looks at it every
``stop_check_s``, so a stop takes effect between passes, never in the middle of one. Here at
the bottom layer so each app's loop shares it."""

from __future__ import annotations

import signal
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from django.core.management.base import BaseCommand


class LoopCommand(BaseCommand):
    # How often the idle wait looks at the stop flag (seconds).
    stop_check_s = 0.1
    # The idle wait's sleep and the clock; tests replace them on the instance.
    sleep: Callable[[float], None] = staticmethod(time.sleep)
    clock: Callable[[], float] = staticmethod(time.monotonic)
    stopping = False

    @contextmanager
    def stopped_by_signals(self) -> Iterator[None]:
        """SIGTERM and SIGINT set ``self.stopping`` while inside; the old handlers after."""
        self.stopping = False
        previous = {s: signal.signal(s, self._stop) for s in (signal.SIGTERM, signal.SIGINT)}
        try:
            yield
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)

    def _stop(self, signum: int, frame: Any) -> None:
        self.stopping = True

    def wait(self, seconds: float) -> None:
        """Sleep ``seconds`` in short steps, returning early once the stop flag is set."""
        remaining = seconds
        while remaining > 0 and not self.stopping:
            step = min(self.stop_check_s, remaining)
            self.sleep(step)
            remaining -= step
