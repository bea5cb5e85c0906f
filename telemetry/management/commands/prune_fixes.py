"""Thin fixes older than the retention to the first and last of each interval (issue 19 item 6).

`prune_fixes` thins every vessel's fixes older than FIX_RETENTION_DAYS to the first and last
fix of each FIX_THIN_INTERVAL_S, keeping every fix an alert points at (telemetry/retention.py),
in short transactions that let the boats' posts through; `--dry-run` only counts. It prints,
per vessel, how many fixes older than the cutoff it read and how many it deleted (or would).
Stopped (SIGTERM, Ctrl-C) it ends between two reads; run again, it carries on where it stopped.
"""

from __future__ import annotations

import signal
from typing import Any

from django.conf import settings
from django.core.management.base import BaseCommand, CommandError, CommandParser
from django.utils import timezone

from telemetry.retention import PruneResult, fixes_prune
from vessels.models import Vessel


class Command(BaseCommand):
    help = __doc__.splitlines()[0]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.stopping = False

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("slugs", nargs="*", help="vessel slugs (default: every vessel)")
        parser.add_argument("--dry-run", action="store_true", help="count, delete nothing")
        parser.add_argument(
            "--older-than-days",
            type=int,
            help="thin fixes older than this many days (default FIX_RETENTION_DAYS)",
        )
        parser.add_argument(
            "--interval", type=int, help="seconds per kept pair (default FIX_THIN_INTERVAL_S)"
        )
        parser.add_argument(
            "--rescan",
            action="store_true",
            help="read each vessel's history from its first fix, not from where the last run "
            "stopped (thins fixes that arrived late, after their time was thinned)",
        )

    def handle(self, *args: Any, slugs: list[str], **opts: Any) -> None:
        days = opts["older_than_days"]
        interval = opts["interval"]
        if days is not None and days < 1:
            raise CommandError("--older-than-days must be at least 1")
        if interval is not None and not 1 <= interval <= 86400:
            raise CommandError("--interval must be 1 to 86400 seconds")
        if days is None and not settings.FIX_RETENTION_DAYS:
            self.stdout.write(
                "FIX_RETENTION_DAYS is 0: every fix is kept. Set it, or pass --older-than-days."
            )
            return
        vessels = Vessel.objects.order_by("pk")
        if slugs:
            vessels = vessels.filter(slug__in=slugs)
            missing = set(slugs) - set(vessels.values_list("slug", flat=True))
            if missing:
                raise CommandError(f"no such vessel: {', '.join(sorted(missing))}")
        previous = {s: signal.signal(s, self._stop) for s in (signal.SIGTERM, signal.SIGINT)}
        try:
            result = fixes_prune(
                now=timezone.now(),
                older_than_days=days,
                interval_s=interval,
                dry_run=opts["dry_run"],
                vessels=vessels,
                rescan=opts["rescan"],
                stop=lambda: self.stopping,
            )
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        self.report(result)

    def _stop(self, signum: int, frame: Any) -> None:
        self.stopping = True

    def report(self, result: PruneResult) -> None:
        assert result.cutoff is not None
        verb = "would delete" if result.dry_run else "deleted"
        self.stdout.write(
            f"Fixes before {result.cutoff:%Y-%m-%d %H:%M}Z, thinned to the first and last of "
            f"each {result.interval_s} s{' (dry run: nothing deleted)' if result.dry_run else ''}:"
        )
        for v in result.vessels:
            self.stdout.write(
                f"{v.slug}: {v.examined:,} read, {verb} {v.deleted:,}, kept {v.kept:,}"
            )
        if not result.vessels:
            self.stdout.write("nothing to thin")
        else:
            self.stdout.write(f"total: {result.examined:,} read, {verb} {result.deleted:,}")
        if not result.finished:
            self.stdout.write("stopped early: run again to carry on")
