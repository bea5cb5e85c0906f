"""The glider's fixes: the time and position in the C&C's status requests, stored as the vessel's
fixes through ``telemetry.services.fix_ingest``.

References (docs/level2.md, its § table): §8.3 (the status request: UTC time, position, 'Y' when
valid), §10 (a retry repeats the request); a Fix is unique on vessel + recorded_at;
issue 11 §4 ("one per distinct C&C time, not one per retry").

* The C&C's time is the fix's time, so a retry (or a new poll with a GPS time that has not moved)
  is a duplicate, never a new fix: counted here for recent times, and by the database's unique
  (vessel, recorded_at) after a restart.
* A fix with no usable time (``Fix.time`` None: the no-fix pattern or an impossible date) is
  logged and dropped, as is one ``fix_ingest`` finds implausible (before 2018, or further ahead
  than FIX_MAX_FUTURE_S). Stamping it with the receive time instead would make every retry a
  new fix and scatter the track with positions the C&C itself did not vouch for.
* Fixes are written in small batches (every ``batch_size`` fixes or ``max_wait_s`` seconds) so
  the runner thread spends under a millisecond per status request; :meth:`FixRecorder.flush`
  writes at once (a power-down notice, a clean stop). A batch the database refuses stays
  pending, bounded by ``max_pending`` (oldest out first, counted).
* Each fix carries the sensor readings known when the request came.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

from django.db import DatabaseError

from sms.level2.payload import Fix
from telemetry.services import IngestResult, fix_ingest
from vessels.models import Vessel

log = logging.getLogger(__name__)

BATCH_SIZE = 10
MAX_WAIT_S = 10.0
MAX_PENDING = 1_000  # ~17 min of 1 s polls; hours of the real 20 s period
RECENT_TIMES = 64  # retries come within seconds (§10): a few recent times are plenty


class FixRecorder:
    """Collect the C&C's fixes and store them in batches for ``vessel``."""

    def __init__(
        self,
        *,
        vessel: Vessel,
        readings: Callable[[], Mapping[str, float]] = dict,
        batch_size: int = BATCH_SIZE,
        max_wait_s: float = MAX_WAIT_S,
        max_pending: int = MAX_PENDING,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.vessel = vessel
        self.readings = readings
        self.batch_size = batch_size
        self.max_wait_s = max_wait_s
        self.clock = clock
        self._pending: deque[dict[str, Any]] = deque(maxlen=max_pending)
        self._first_pending_at: float | None = None
        self._recent: deque = deque(maxlen=RECENT_TIMES)
        # record() runs in the serial runner's thread, flush() in the bridge loop's.
        self._lock = threading.Lock()
        self.received = 0
        self.duplicates = 0
        self.no_time = 0
        self.evicted = 0
        self.stored = 0
        self.rejected = 0

    @property
    def pending(self) -> int:
        return len(self._pending)

    def record(self, fix: Fix) -> bool:
        """Take one fix from a status request; True if it is new and will be stored."""
        self.received += 1
        if fix.time is None:
            self.no_time += 1
            log.warning("fix without a usable C&C time dropped: %.5f, %.5f", fix.lat, fix.lon)
            return False
        if fix.time in self._recent:
            self.duplicates += 1
            return False
        self._recent.append(fix.time)
        record = {
            "time": fix.time.isoformat(),
            "lat": fix.lat,
            "lon": fix.lon,
            "readings": dict(self.readings()),
        }
        with self._lock:
            if len(self._pending) == self._pending.maxlen:
                self.evicted += 1  # the deque drops the oldest
            self._pending.append(record)
            if self._first_pending_at is None:
                self._first_pending_at = self.clock()
        return True

    def due(self) -> bool:
        first = self._first_pending_at
        if first is None or not self._pending:
            return False
        return len(self._pending) >= self.batch_size or self.clock() - first >= self.max_wait_s

    def flush_if_due(self) -> bool:
        """One unit for the bridge loop: store the batch if it is due; True if it was."""
        return self.due() and self.flush() is not None

    def flush(self) -> IngestResult | None:
        """Store every pending fix now; None (fixes kept) if the database refused."""
        with self._lock:
            batch = list(self._pending)
        if not batch:
            return None
        try:
            result = fix_ingest(vessel=self.vessel, records=batch)
        except DatabaseError as exc:
            log.warning("%d fixes kept for later: the database refused them: %s", len(batch), exc)
            return None
        flushed = {id(record) for record in batch}
        with self._lock:
            # Fixes recorded meanwhile stay; ones evicted meanwhile are gone already.
            while self._pending and id(self._pending[0]) in flushed:
                self._pending.popleft()
            self._first_pending_at = self.clock() if self._pending else None
        self.stored += result.accepted
        self.duplicates += result.duplicates
        for rejection in result.rejected:
            self.rejected += 1
            log.warning(
                "fix dropped: %s (%s)", rejection["errors"], batch[rejection["index"]]["time"]
            )
        return result
