"""Rebuild the track overview (map and plot summaries) from the fixes, for some or all vessels.

Needed only after fixes were written around the ingest service (a bulk load, a restore, a
delete in SQL); ingest and the admin keep the overview up to date themselves.
"""

from __future__ import annotations

import time
from typing import Any

from django.core.management.base import BaseCommand, CommandError, CommandParser

from telemetry.services import track_overview_rebuild
from vessels.models import Vessel


class Command(BaseCommand):
    help = __doc__.splitlines()[0]

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("slugs", nargs="*", help="vessel slugs (default: every vessel)")

    def handle(self, *args: Any, slugs: list[str], **options: Any) -> None:
        vessels = Vessel.objects.order_by("slug")
        if slugs:
            vessels = vessels.filter(slug__in=slugs)
            missing = set(slugs) - set(vessels.values_list("slug", flat=True))
            if missing:
                raise CommandError(f"no such vessel: {', '.join(sorted(missing))}")
        for vessel in vessels:
            started = time.monotonic()
            track_overview_rebuild(vessel=vessel)
            self.stdout.write(f"{vessel.slug}: rebuilt in {time.monotonic() - started:.1f} s")
