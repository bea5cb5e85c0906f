from __future__ import annotations

import signal
import time
from typing import Any

from django.core.management.base import BaseCommand, CommandParser
from django.db import close_old_connections

from commands.services import command_expire_due


class Command(BaseCommand):
    help = "Expire queued commands past their expires_at (once, or in a loop with --loop)."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--loop", action="store_true")
        parser.add_argument("--interval", type=float, default=60.0)

    def handle(self, *args: Any, **opts: Any) -> None:
        self.stopping = False
        signal.signal(signal.SIGTERM, self._stop)
        signal.signal(signal.SIGINT, self._stop)
        while True:
            self.do_one_pass()
            if not opts["loop"] or self.stopping:
                return
            deadline = time.monotonic() + opts["interval"]
            while not self.stopping and time.monotonic() < deadline:
                time.sleep(0.2)
            if self.stopping:
                return

    def _stop(self, signum: int, frame: Any) -> None:
        self.stopping = True

    def do_one_pass(self) -> int:
        close_old_connections()
        count = command_expire_due()
        if count:
            self.stdout.write(f"expired {count} command(s)")
        return count
