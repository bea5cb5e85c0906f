"""`manage.py expire_commands`: expire queued commands past their expires_at.

Once (for cron), or with ``--loop`` beside the web server in the shape of healthchecks'
``sendalerts``: SIGTERM/SIGINT only set a flag, and a pass that fails (the database restarting,
a lost connection) is logged and retried on the next pass instead of ending the process, which
systemd would only restart into the same error.
"""

from __future__ import annotations

import logging
from typing import Any

from django.core.management.base import CommandParser
from django.db import close_old_connections

from commands.services import command_expire_due
from vessels.loops import LoopCommand

logger = logging.getLogger(__name__)


class Command(LoopCommand):
    help = "Expire queued commands past their expires_at (once, or in a loop with --loop)."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--loop", action="store_true")
        parser.add_argument("--interval", type=float, default=60.0)

    def handle(self, *args: Any, **opts: Any) -> None:
        with self.stopped_by_signals():
            if opts["loop"]:
                self.run_loop(interval=opts["interval"])
            else:
                self.do_one_pass()  # cron: a failure fails the run, so cron reports it

    def run_loop(self, *, interval: float) -> None:
        """Pass, wait ``interval`` seconds, repeat until the stop flag is set."""
        while not self.stopping:
            self.do_one_guarded_pass()
            self.wait(interval)

    def do_one_guarded_pass(self) -> bool:
        """One pass that never raises: a failure is logged and the loop carries on."""
        try:
            self.do_one_pass()
        except Exception:
            logger.exception("expire_commands: the pass failed; trying again next pass")
            return False
        finally:
            # A connection the failure left broken is dropped here, not reused next pass.
            close_old_connections()
        return True

    def do_one_pass(self) -> int:
        close_old_connections()
        count = command_expire_due()
        if count:
            self.stdout.write(f"expired {count} command(s)")
        return count
