"""`manage.py run_alerts [--period S] [--once]`: evaluate the alert rules, send what is due.

The shape of healthchecks' ``sendalerts`` (as expire_commands and rebuild_track_overview):

- SIGTERM and SIGINT only set a flag; the loop stops between passes (or in its idle wait);
- each pass is ``do_one_pass() -> bool``: the evaluator's pass (alerts/evaluator.py), then the
  notifications due (alerts/services/notifications.py ``notifications_send_due``, which claims
  each with a conditional UPDATE, so two copies side by side never send one twice);
- a pass that fails (the database restarting) is logged and tried again next period; a rule
  that fails is pushed aside by the evaluator; nothing makes the process exit and crash-loop;
- ``close_old_connections()`` around every pass;
- with ALERTS_PRUNE_EVERY_S set, old fixes are thinned (telemetry's ``fixes_prune``) in a
  thread of its own, so a long prune never delays a pass.

Ingest never waits for any of it: the loop only reads fixes and vessels, and writes alerts.
"""

from __future__ import annotations

import datetime as dt
import logging
import os
import socket
import threading
from typing import Any

from django.conf import settings
from django.core.management.base import CommandParser
from django.db import close_old_connections, connection
from django.utils import timezone

from alerts.evaluator import Evaluator
from alerts.services.notifications import notifications_send_due
from telemetry.retention import fixes_prune
from vessels.loops import LoopCommand

logger = logging.getLogger(__name__)


class Command(LoopCommand):
    help = __doc__.splitlines()[0]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.worker = f"{socket.gethostname()}:{os.getpid()}"
        self.evaluator: Evaluator | None = None
        self.pruner: threading.Thread | None = None
        self.pruned_at: float | None = None

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument(
            "--period",
            type=float,
            default=None,
            help="seconds between passes (default: ALERTS_PERIOD_S)",
        )
        parser.add_argument("--once", action="store_true", help="one pass, then exit")

    def handle(self, *args: Any, **opts: Any) -> None:
        period = opts["period"] or settings.ALERTS_PERIOD_S
        with self.stopped_by_signals():
            if opts["once"]:
                # One pass from cron: judge the fixes of the last period (and the overlap).
                self.evaluator = Evaluator(since=timezone.now() - dt.timedelta(seconds=period))
                if not self.do_one_pass():
                    raise SystemExit(1)
                return
            self.evaluator = Evaluator()
            self.stdout.write(f"run_alerts: started, a pass every {period:g} s ({self.worker})")
            self.stdout.flush()
            self.run_loop(period=period)
            self.stdout.write("run_alerts: stopped")

    def run_loop(self, *, period: float) -> None:
        """Pass, wait out the rest of the period, repeat until the stop flag is set."""
        while not self.stopping:
            started = self.clock()
            self.do_one_pass()
            self.prune_when_due()
            self.wait(period - (self.clock() - started))
        if self.pruner is not None:
            self.pruner.join(timeout=5)  # a batch in flight commits or rolls back alone

    def do_one_pass(self) -> bool:
        """Evaluate, then send what is due; False when either failed (logged, not raised)."""
        assert self.evaluator is not None
        ok = True
        close_old_connections()
        try:
            report = self.evaluator.run_pass()
            if report.opened or report.resolved or report.failed_rules:
                self.stdout.write(
                    f"run_alerts: {report.opened} opened, {report.resolved} resolved, "
                    f"{len(report.failed_rules)} rule(s) failing"
                )
        except Exception:
            logger.exception("run_alerts: the pass failed; trying again next period")
            ok = False
        finally:
            close_old_connections()
        return self.send_due() and ok

    def send_due(self) -> bool:
        try:
            notifications_send_due(
                now=timezone.now(), worker=self.worker, stop=lambda: self.stopping
            )
        except Exception:
            logger.exception("run_alerts: sending notifications failed; trying again")
            return False
        finally:
            close_old_connections()
        return True

    def prune_when_due(self) -> None:
        """Start a prune in its own thread every ALERTS_PRUNE_EVERY_S (0: never), one at a
        time."""
        every = settings.ALERTS_PRUNE_EVERY_S
        if not every or (self.pruner is not None and self.pruner.is_alive()):
            return
        if self.pruned_at is not None and self.clock() - self.pruned_at < every:
            return
        self.pruned_at = self.clock()
        self.pruner = threading.Thread(target=self._prune, name="run_alerts-prune", daemon=True)
        self.pruner.start()

    def _prune(self) -> None:
        try:
            # Thinning stops between two reads once the loop is asked to stop.
            fixes_prune(now=timezone.now(), stop=lambda: self.stopping)
        except Exception:
            logger.exception("run_alerts: pruning fixes failed; trying again later")
        finally:
            connection.close()  # this thread's own connection
