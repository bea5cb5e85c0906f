"""`manage.py run_links [--period S] [--once]`: per-vessel routing, one pass every period.

Each pass relays the queued commands that should not wait for HTTP alone (an urgent command,
a vessel silent over HTTP past its schedule) by SMS or Iridium SBD (fleet/routing.py), then
tries the SBD messages still queued for RockBLOCK (``sbd_send_queued``). The shape of
run_alerts: SIGTERM and SIGINT stop it between passes; a pass that fails (the database
restarting, a provider down) is logged and tried again next period, never ends the process.
With no SMS sender and no SBD account configured a pass does nothing, and says so at start.
"""

from __future__ import annotations

import logging
from typing import Any

from django.conf import settings
from django.core.management.base import CommandParser
from django.db import close_old_connections

from fleet.relays import configured_senders
from fleet.routing import route_pending
from sbd.services import sbd_send_queued
from vessels.loops import LoopCommand

logger = logging.getLogger(__name__)


class Command(LoopCommand):
    help = __doc__.splitlines()[0]

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument(
            "--period", type=float, default=None, help="seconds between passes "
            "(default: LINKS_ROUTE_PERIOD_S)"
        )  # fmt: skip
        parser.add_argument("--once", action="store_true", help="one pass, then exit")

    def handle(self, *args: Any, **opts: Any) -> None:
        period = opts["period"] or settings.LINKS_ROUTE_PERIOD_S
        senders = configured_senders()
        ways = ", ".join(sorted(route.value for route in senders)) or "none configured"
        with self.stopped_by_signals():
            if opts["once"]:
                if not self.do_one_pass(senders):
                    raise SystemExit(1)
                return
            self.stdout.write(f"run_links: started, a pass every {period:g} s; relays: {ways}")
            self.stdout.flush()
            while not self.stopping:
                started = self.clock()
                self.do_one_pass(senders)
                self.wait(period - (self.clock() - started))
            self.stdout.write("run_links: stopped")

    def do_one_pass(self, senders: dict) -> bool:
        """Route, then retry the SBD queue; False when it failed (logged, not raised)."""
        close_old_connections()
        try:
            report = route_pending(senders=senders)
            for uid, route in report.relayed:
                self.stdout.write(f"run_links: command {uid} relayed by {route.value}")
            for uid in report.impossible:
                self.stdout.write(f"run_links: command {uid}: no link could carry it")
            sbd_send_queued()
        except Exception:
            logger.exception("run_links: the pass failed; trying again next period")
            return False
        finally:
            close_old_connections()
        return True
