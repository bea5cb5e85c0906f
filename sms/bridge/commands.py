"""The database as the payload machine's command source (``sms.level2.payload.CommandSource``).

References (docs/level2.md, its § table): §8.4 (the status flag), §8.5 (request queued and its
reply), §8.6 (the C&C's ACK/NAK queued message: a code and no reference to the command), §10
(the C&C resends a request with the same tid ~2 s apart, 3 attempts); docs/api.md (lifecycle),
docs/wave-glider.md (the bridge); issue 11 §2.

The vessel's queued commands go to the C&C oldest first, whatever created them (SMS, admin,
API). Every step is a conditional UPDATE through ``commands.services`` and leaves a
CommandEvent with the detail:

1. ``pending_count`` (every status request, ~1/s): one indexed COUNT, or no query at all while a
   command is in flight or in quarantine.
2. ``take_next`` (request queued): the oldest queued command is encoded with the inner command
   table; a refused one is failed with the table's reason and never sent; the first good one
   is marked ``sent`` with the request's tid and source in its event (``CommandEvent.tid``,
   ``src_task``, ``src_board``), *before* the reply is written.
3. ``complete`` / ``result_without_command``: an ACK makes it ``done`` (through
   ``acknowledged``), a NAK ``failed`` with the code's meaning (``CommandEvent.cc_code`` and
   ``cc_reason``; the SMS replies read these, the detail beside them is for people).
4. ``expire_overdue`` (the bridge loop, about once a second): no answer within
   ``result_timeout_s`` fails it, "no answer from the C&C box"; once a minute, queued commands
   past their ``expires_at`` become ``expired`` (the queries never offer them anyway).
5. ``flush_results`` (the bridge loop, a power-down notice): answers the database refused
   (locked too long) are kept in memory and written then; no database error ever reaches the
   Level 2 reply path.

Threads: the serial runner's thread calls 1–3, the bridge loop 4–5; the in-memory state (the
command in flight, the quarantine) is under one lock, and whoever takes the command in flight
first settles it (the conditional UPDATEs make a second writer a no-op).

Why one command at a time, and the quarantine: results carry no command reference (§8.6), so
they can only be matched in order. With several commands out, one lost result would shift every
later result onto the wrong command. With one out, the next result is unambiguous while the C&C
answers. A timeout breaks that: A's result may still be on its way. If B went out at once, A's
late result would be credited to B. So after a timeout nothing is handed over for
``quarantine_s``: a result arriving then is A's, logged (and noted on A) and credited to nobody.
A result later than timeout + quarantine is indistinguishable from the next command's answer:
choose the two well above the C&C's worst delay. The cost: one command per status poll.

Crash safety (the source keeps its state in the database, not in memory):

* killed between the flag and the handover: the command is still ``queued``; the next request
  takes it. Nothing was handed over.
* killed after ``sent`` was committed (whether or not the reply left): on restart the newest
  ``sent`` command is in flight again, with its timeout running from ``sent_at``. The tid of its
  request is on its sent event, so the C&C's retry of that request (same tid, §10) is answered
  with the same command, not with a second one; the machine's own reply cache died with it.
  A result arriving after the restart comes as ``ResultWithoutCommand`` (the new machine has no
  record of the handover) and is credited to the command in flight.
* killed during a quarantine: it runs on after the restart (read back from the timeout's event).
"""

from __future__ import annotations

import datetime as dt
import logging
import threading
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from django.db import DatabaseError, OperationalError
from django.db.models import QuerySet
from django.utils import timezone

from commands.lifecycle import Status
from commands.models import Command
from commands.services import (
    command_complete,
    command_expire_due,
    command_fail_unsent,
    command_mark_sent,
    command_note,
)
from sms import selectors, sql
from sms.level2.bodies import response_meaning
from sms.level2.codec import Address, Frame, MessageType
from sms.level2.errors import CommandRefused
from sms.level2.inner import InnerCommandTable
from sms.level2.payload import CommandResult, QueuedCommand
from vessels.models import Vessel

log = logging.getLogger(__name__)

ACTOR = "wg-bridge"
# A command's result_detail, as the bridge writes it for people (code reads the event's fields):
ACK_DETAIL = "C&C: ACK (accepted)"
NAK_DETAIL = "C&C: NAK {code}: {meaning}"  # meaning: sms.level2.bodies.response_meaning
NO_ANSWER = "no answer from the C&C box"
REFUSED_DETAIL = "refused by the inner command table: {reason}"
# The real C&C answered the one captured command at once (§8.6); three 20 s poll periods is
# generous, and the quarantine equals it (see the module docstring).
RESULT_TIMEOUT_S = 60.0
QUARANTINE_S = 60.0
# §10: a retry comes ~2 s after the first attempt, the third ~4 s after it; margin for a slow
# restart. A request with the same tid after this window is a new one (the C&C's counter wraps).
RETRY_WINDOW_S = 10.0

# The sent event's detail says which request took the command; its fields (tid, src_task,
# src_board) keep the same for a restarted bridge, to answer the C&C's retry identically.
_HANDOVER = "handed over to the C&C in reply to request queued tid 0x{tid:04X} from {src}"
_HANDOVER_UNKNOWN = "handed over to the C&C"
_NO_INDEX = object()  # _query_waiting could not use sms.sql.OPEN_INDEX
# Queued commands past expires_at are never offered (the queries skip them); marking them
# expired walks the vessel's history, so the bridge loop does it this often, not every request.
EXPIRY_SWEEP_S = 60.0


@dataclass(frozen=True)
class InFlight:
    """The command handed over whose answer has not come yet."""

    pk: int
    uid: str
    sent_at: dt.datetime
    queued: QueuedCommand | None  # None if the table no longer encodes it (after a restart)
    tid: int | None = None  # of the request it answered: a retry with it gets the same reply
    src: Address | None = None


@dataclass(frozen=True)
class _Outcome:
    flight: InFlight
    status: Status
    detail: str
    answer: str
    at: dt.datetime
    code: int | None = None  # the C&C's answer code; None: it never answered
    reason: str = ""  # a NAK code's meaning


class DatabaseCommandSource:
    """The vessel's queued commands, one handover at a time (see the module docstring).

    Thread-safe: the serial runner's thread calls the CommandSource methods, the bridge loop
    calls :meth:`expire_overdue`; whoever takes the in-flight command first settles it.
    """

    def __init__(
        self,
        *,
        vessel: Vessel,
        table: InnerCommandTable | None = None,
        result_timeout_s: float = RESULT_TIMEOUT_S,
        quarantine_s: float = QUARANTINE_S,
        retry_window_s: float = RETRY_WINDOW_S,
        clock: Callable[[], dt.datetime] = timezone.now,
    ) -> None:
        self.vessel = vessel
        self.table = table or InnerCommandTable.load()
        self.result_timeout = dt.timedelta(seconds=result_timeout_s)
        self.quarantine = dt.timedelta(seconds=quarantine_s)
        self.retry_window = dt.timedelta(seconds=retry_window_s)
        self.clock = clock
        self._lock = threading.Lock()
        self._request: Frame | None = None
        self._in_flight: InFlight | None = None
        self._quarantine_until: dt.datetime | None = None
        self._timed_out: InFlight | None = None  # the last command that timed out
        self._unsaved: list[_Outcome] = []  # results the database refused, for flush_results
        self._indexed_query_failed = False  # see _query_waiting
        self._next_sweep: dt.datetime | None = None  # of command_expire_due
        self.late_results = 0
        self.unmatched_results = 0
        self._restore()

    # -- CommandSource (called by the payload machine, in the Level 2 reply path) ----------------

    def pending_count(self) -> int:
        """Commands waiting; 0 while one is in flight or in quarantine (no query then)."""
        now = self.clock()
        with self._lock:
            if self._in_flight is not None or self._quarantined(now):
                return 0
        try:
            return self._count_waiting(now)
        except DatabaseError as exc:  # e.g. locked for longer than the timeout: flag nothing
            log.error("cannot count queued commands: %s", exc)
            return 0

    def take_next(self) -> QueuedCommand | None:
        """The command for this request queued: the same one again for a retry of the request
        that took it, else the oldest queued one the table encodes (marked sent), else None."""
        now = self.clock()
        with self._lock:
            request = self._request
            flight = self._in_flight
            if flight is not None:
                return self._retried(flight, request, now)
            if self._quarantined(now):
                return None
            try:
                return self._take_oldest(request, now)
            except DatabaseError as exc:
                # Nothing was marked sent (its transaction rolled back): the C&C gets "nothing
                # queued" and the command waits for the next poll.
                log.error("cannot take a command: %s", exc)
                return None

    def _take_oldest(self, request: Frame | None, now: dt.datetime) -> QueuedCommand | None:
        while (command := self._oldest_waiting(now)) is not None:
            handed = self._hand_over(command, request, now)
            if handed is not None:
                return handed
        return None

    def complete(self, result: CommandResult) -> None:
        """The machine matched a result to a handover it remembers: credit the command in
        flight (after a timeout the machine's own order is stale; ours is the one that counts)."""
        self._credit(result.code, result.meaning, machine_ident=result.ident)

    # -- hooks for the bridge -------------------------------------------------------------------

    def note_request(self, frame: Frame) -> None:
        """The request being handled now (called before the machine handles it)."""
        if frame.msg_type == MessageType.REQUEST_QUEUED:
            with self._lock:
                self._request = frame

    def result_without_command(self, code: int) -> None:
        """A result the machine could not match (it restarted since the handover): ours."""
        self._credit(code, response_meaning(code), machine_ident=None)

    def forget_request_ids(self) -> None:
        """The C&C enumerated again (it restarted): its tids start over, so no later request
        is a retry of the one that took the command in flight."""
        with self._lock:
            if self._in_flight is not None:
                self._in_flight = replace(self._in_flight, tid=None, src=None)

    def expire_overdue(self) -> bool:
        """One unit for the bridge loop: fail the command in flight if its answer is overdue
        (True if one was failed); every EXPIRY_SWEEP_S, mark queued commands past their
        expires_at expired."""
        now = self.clock()
        if self._next_sweep is None or now >= self._next_sweep:
            self._next_sweep = now + dt.timedelta(seconds=EXPIRY_SWEEP_S)
            try:
                command_expire_due(vessel=self.vessel, now=now)
            except DatabaseError as exc:
                log.error("cannot expire queued commands: %s", exc)
        with self._lock:
            flight = self._in_flight
            if flight is None or now - flight.sent_at < self.result_timeout:
                return False
            self._in_flight = None
            self._timed_out = flight
            self._quarantine_until = now + self.quarantine
        log.warning("command %s: %s", flight.uid, NO_ANSWER)
        self._settle(_Outcome(flight, Status.FAILED, NO_ANSWER, NO_ANSWER, now))
        return True

    def flush_results(self) -> int:
        """Write the results the database refused earlier (the bridge loop, a power-down
        notice); returns how many are still unsaved."""
        with self._lock:
            unsaved, self._unsaved = self._unsaved, []
        for outcome in unsaved:
            self._settle(outcome)
        with self._lock:
            return len(self._unsaved)

    @property
    def in_flight(self) -> InFlight | None:
        with self._lock:
            return self._in_flight

    # -- internals ------------------------------------------------------------------------------

    def _count_waiting(self, now: dt.datetime) -> int:
        found = self._query_waiting(sql.queued_count, now)
        return self._waiting(now).count() if found is _NO_INDEX else found

    def _oldest_waiting(self, now: dt.datetime) -> Command | None:
        found = self._query_waiting(sql.queued_oldest_id, now)
        if found is _NO_INDEX:
            return self._waiting(now).order_by("created_at", "pk").first()
        return None if found is None else selectors.bridge_command(found)

    def _query_waiting(self, query: Callable[[int, dt.datetime], Any], now: dt.datetime) -> Any:
        """``query`` (one of sms.sql's queued_* reads, written out for the status request's
        hot count: see there), or _NO_INDEX if its index cannot be used (the caller then asks
        the ORM). Should the index ever change, the ORM takes over (logged) rather than the
        flag going silent.
        """
        if self._indexed_query_failed:
            return _NO_INDEX
        try:
            return query(self.vessel.pk, now)
        except OperationalError as exc:
            if "no query solution" not in str(exc) and "no such index" not in str(exc):
                raise
            self._indexed_query_failed = True
            log.error(
                "queued commands: cannot use index %s (%s); the ORM takes over",
                sql.OPEN_INDEX,
                exc,
            )
            return _NO_INDEX

    def _waiting(self, now: dt.datetime) -> QuerySet[Command]:
        return selectors.bridge_commands_waiting(vessel_id=self.vessel.pk, now=now)

    def _quarantined(self, now: dt.datetime) -> bool:
        return self._quarantine_until is not None and now < self._quarantine_until

    def _hand_over(
        self, command: Command, request: Frame | None, now: dt.datetime
    ) -> QueuedCommand | None:
        """Encode and mark sent; a refused command is failed. None if it was not handed over."""
        try:
            inner = self.table.encode(command.kind, command.params)
        except CommandRefused as exc:
            reason = REFUSED_DETAIL.format(reason=exc.reason)
            command_fail_unsent(
                command=command, reason=reason, actor=ACTOR, now=now, cc_reason=exc.reason
            )
            log.warning("command %s (%s) failed unsent: %s", command.uid, command.kind, reason)
            return None
        detail, taken_by = _HANDOVER_UNKNOWN, {}
        if request is not None:
            detail = _HANDOVER.format(
                tid=request.tid, src=f"{request.src_task}/{request.src_board}"
            )
            taken_by = {
                "tid": request.tid,
                "src_task": request.src_task,
                "src_board": request.src_board,
            }
        if not command_mark_sent(command=command, actor=ACTOR, detail=detail, now=now, **taken_by):
            return None  # cancelled, superseded or expired a moment ago: never hand it over
        queued = QueuedCommand(str(command.uid), inner)
        self._in_flight = InFlight(
            command.pk,
            str(command.uid),
            now,
            queued,
            request.tid if request else None,
            request.src if request else None,
        )
        return queued

    def _retried(
        self, flight: InFlight, request: Frame | None, now: dt.datetime
    ) -> QueuedCommand | None:
        """The same command for a retry of its request (§10), else None: one at a time."""
        if (
            request is None
            or flight.queued is None
            or (flight.tid, flight.src) != (request.tid, request.src)
            or now - flight.sent_at > self.retry_window
        ):
            return None
        detail = f"the C&C repeated request queued tid 0x{request.tid:04X}: answered again"
        log.info("command %s: %s", flight.uid, detail)
        self._note(flight.pk, detail, now)
        return flight.queued

    def _note(self, pk: int, detail: str, now: dt.datetime) -> None:
        """A note on a command's log; the log line already went out, so a refusal is logged."""
        try:
            command_note(command=selectors.bridge_command(pk), detail=detail, actor=ACTOR, now=now)
        except DatabaseError as exc:
            log.error("note not saved (%s): %s", exc, detail)

    def _credit(self, code: int, meaning: str, *, machine_ident: str | None) -> None:
        now = self.clock()
        with self._lock:
            flight = self._in_flight
            self._in_flight = None
            timed_out = self._timed_out if self._quarantined(now) else None
        answer = "ACK" if code == 0 else f"NAK {code}: {meaning}"
        if flight is None:
            self._log_unmatched(answer, timed_out, now)
            return
        if machine_ident is not None and machine_ident != flight.uid:
            log.info("result the machine matched to %s credited to %s", machine_ident, flight.uid)
        status = Status.DONE if code == 0 else Status.FAILED
        detail = NAK_DETAIL.format(code=code, meaning=meaning) if code else ACK_DETAIL
        reason = meaning if code else ""
        self._settle(_Outcome(flight, status, detail, answer, now, code, reason))

    def _settle(self, outcome: _Outcome) -> bool:
        """Write one outcome; if the database refuses, keep it for :meth:`flush_results`."""
        try:
            command = selectors.bridge_command(outcome.flight.pk)
            if not command_complete(
                command=command,
                status=outcome.status,
                detail=outcome.detail,
                actor=ACTOR,
                now=outcome.at,
                cc_code=outcome.code,
                cc_reason=outcome.reason,
            ):
                note = (
                    f"the C&C answered {outcome.answer} after the command became {command.status}"
                )
                if outcome.answer == NO_ANSWER:
                    note = f"{NO_ANSWER}, but the command had become {command.status}"
                command_note(command=command, detail=note, actor=ACTOR, now=outcome.at)
                log.warning("command %s: %s", outcome.flight.uid, note)
        except DatabaseError as exc:
            log.error("command %s: result kept for later, database: %s", outcome.flight.uid, exc)
            with self._lock:
                self._unsaved.append(outcome)
            return False
        return True

    def _log_unmatched(self, answer: str, timed_out: InFlight | None, now: dt.datetime) -> None:
        if timed_out is None:
            self.unmatched_results += 1
            log.warning("result from the C&C with no command in flight, dropped: %s", answer)
            return
        self.late_results += 1
        note = f"late answer from the C&C after the timeout, not credited: {answer}"
        log.warning("command %s: %s", timed_out.uid, note)
        self._note(timed_out.pk, note, now)

    def _restore(self) -> None:
        """After a restart: the newest sent command is in flight again; older ones failed.

        With one handover at a time there is at most one, unless an older bridge left more.
        A quarantine still running when the bridge stopped runs on (else a late answer for
        the command that timed out could be credited to the next one after a quick restart).
        """
        self._restore_quarantine()
        sent = selectors.bridge_commands_sent(vessel_id=self.vessel.pk)
        if not sent:
            return
        newest, older = sent[0], sent[1:]
        for command in older:
            command_complete(command=command, status=Status.FAILED, detail=NO_ANSWER, actor=ACTOR)
        try:
            queued: QueuedCommand | None = QueuedCommand(
                str(newest.uid), self.table.encode(newest.kind, newest.params)
            )
        except CommandRefused:
            queued = None  # the table changed since: a retry cannot be answered identically
        tid, src = _handover_request(newest)
        self._in_flight = InFlight(
            newest.pk, str(newest.uid), newest.sent_at or self.clock(), queued, tid, src
        )
        log.info(
            "command %s was in flight when the bridge stopped: awaiting its answer",
            newest.uid,
        )

    def _restore_quarantine(self) -> None:
        now = self.clock()
        last = selectors.bridge_last_timeout(
            vessel_id=self.vessel.pk, actor=ACTOR, detail=NO_ANSWER, since=now - self.quarantine
        )
        if last is not None:
            command = last.command
            self._quarantine_until = last.at + self.quarantine
            self._timed_out = InFlight(command.pk, str(command.uid), last.at, None)


def _handover_request(command: Command) -> tuple[int | None, Address | None]:
    """The tid and source of the request that took ``command``, from its sent event."""
    event = selectors.bridge_handover_event(command=command, actor=ACTOR)
    if event is None or None in (event.tid, event.src_task, event.src_board):
        return None, None
    return event.tid, Address(event.src_task, event.src_board)
