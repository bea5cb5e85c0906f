"""Rebuild the track overview (map and plot summaries): whole, or its out-of-date minutes.

`rebuild_track_overview [slug …]` rebuilds some or all vessels' overview from their fixes: needed
after fixes were written around the ingest service (a bulk load, a restore, a delete in SQL).

`rebuild_track_overview --loop` runs beside the web server and rebuilds the minutes ingest and the
admin marked out of date (TrackDirty), every ``--interval`` seconds; `--pending` does one such pass
(cron). Map reads never write: until a minute is rebuilt they read its fixes instead, so answers
are as current without the loop, only slower as marks pile up. The loop has the shape of
healthchecks' ``sendalerts`` (as expire_commands): SIGTERM/SIGINT only set a flag, and a vessel
whose rebuild fails is logged and left alone for a while (doubling, up to an hour) instead of
failing every pass; the other vessels carry on.
"""

from __future__ import annotations

import logging
import time
from typing import Any

from django.core.management.base import CommandError, CommandParser
from django.db import close_old_connections

from edge_client.contract.backoff import UNTIL_THE_CAP, after_failures
from telemetry.services import (
    REBUILD_WINDOW_S,
    track_overview_dirty_vessels,
    track_overview_rebuild,
    track_overview_refresh,
)
from vessels.loops import LoopCommand
from vessels.models import Vessel

logger = logging.getLogger(__name__)

# A vessel whose rebuild failed is retried after this long, doubling per failure, up to the max.
RETRY_FIRST_S = 10.0
RETRY_MAX_S = 3600.0
# A pass rebuilds at most this many windows (a day each) per vessel: a long backlog is spread
# over passes, and a vessel marking a new minute as fast as it is rebuilt cannot hold a pass.
WINDOWS_PER_PASS = 30


def retry_delay(failures: int) -> float:
    """Seconds to leave a vessel alone after its ``failures``-th failure in a row."""
    return after_failures(RETRY_FIRST_S, failures - 1, cap=RETRY_MAX_S, max_doublings=UNTIL_THE_CAP)


class Command(LoopCommand):
    help = __doc__.splitlines()[0]

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        # vessel id -> (failures in a row, when to try again on self.clock)
        self.failures: dict[int, tuple[int, float]] = {}
        self.rebuilt = 0

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("slugs", nargs="*", help="vessel slugs (default: every vessel)")
        parser.add_argument(
            "--loop", action="store_true", help="rebuild out-of-date minutes until stopped"
        )
        parser.add_argument(
            "--pending", action="store_true", help="rebuild out-of-date minutes once"
        )
        parser.add_argument("--interval", type=float, default=10.0)

    def handle(self, *args: Any, slugs: list[str], **opts: Any) -> None:
        if opts["loop"] or opts["pending"]:
            if slugs:
                raise CommandError("--loop and --pending take no vessel slugs")
            with self.stopped_by_signals():
                if opts["loop"]:
                    self.run_loop(interval=opts["interval"])
                else:
                    self.do_one_pass()
            return
        self.rebuild_whole(slugs)

    def rebuild_whole(self, slugs: list[str]) -> None:
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

    def run_loop(self, *, interval: float) -> None:
        """Pass, wait ``interval`` seconds, repeat until the stop flag is set."""
        while not self.stopping:
            try:
                self.do_one_pass()
            except Exception:
                # Listing the vessels failed (the database restarting): try again next pass.
                logger.exception("rebuild_track_overview: the pass failed; trying again")
            finally:
                close_old_connections()
            self.wait(interval)

    def do_one_pass(self) -> int:
        """Rebuild every vessel's out-of-date minutes (but those backing off); how many."""
        close_old_connections()
        total = 0
        for vessel_id in track_overview_dirty_vessels():
            if self.stopping:
                break
            failures, retry_at = self.failures.get(vessel_id, (0, 0.0))
            if failures and self.clock() < retry_at:
                continue
            if self.do_one_vessel(vessel_id):
                self.failures.pop(vessel_id, None)
            else:
                delay = retry_delay(failures + 1)
                self.failures[vessel_id] = (failures + 1, self.clock() + delay)
                logger.warning(
                    "rebuild_track_overview: vessel %s failed %d time(s); next try in %.0f s",
                    vessel_id, failures + 1, delay,
                )  # fmt: skip
                continue
            total += self.rebuilt
        return total

    def do_one_vessel(self, vessel_id: int) -> bool:
        """Rebuild one vessel's out-of-date minutes, a day's worth per transaction; False when
        it failed (logged; what was rebuilt before the failure stays rebuilt)."""
        self.rebuilt = 0
        try:
            for _ in range(WINDOWS_PER_PASS):
                if self.stopping:
                    break
                done = track_overview_refresh(vessel_id=vessel_id, max_span_s=REBUILD_WINDOW_S)
                if not done:
                    break
                self.rebuilt += done
        except Exception:
            logger.exception("rebuild_track_overview: rebuilding vessel %s failed", vessel_id)
            close_old_connections()
            return False
        return True
