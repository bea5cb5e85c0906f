"""The bridge's modem side: SMS in through the SMS service, replies out, in its own thread.

References: issue 11 §1 and §3; docs/wave-glider.md; docs/sms.md, 'The GSM modem' (what a robust
driver does); ``sms.modem.driver`` (THE DELETE CONTRACT: a message is deleted only after
``sms_handle_incoming`` committed it; the service is idempotent on the modem's time stamp, so a
message seen again after a crash is handled once).

Each ``do_one_<thing>()`` is one unit of work that tests call directly; :meth:`SmsLink.run`
loops them until stopped. A failing item is logged and pushed aside:

* an SMS the service cannot store stays on the SIM (``receive_all``) and is tried again at the
  next re-list;
* a reply the modem refuses for good (``+CMS ERROR`` with a permanent code, a text it cannot
  type) is marked failed; a temporary refusal is retried with a doubling backoff, and given up
  (failed) after ``max_attempts``;
* a reply whose text went out with no answer (``SendUnconfirmed``) is marked sent, "unconfirmed":
  sending it again could answer the same SMS twice;
* a database error is logged, the connection closed (the next query reconnects), and the loop
  carries on after a pause: a database restart does not end the process.

Nothing here touches the Level 2 link: it runs in another thread and never waits for this one.
"""

from __future__ import annotations

import datetime as dt
import logging
import threading
import time
from collections.abc import Callable, Mapping

from django.db import DatabaseError, close_old_connections, connection
from django.utils import timezone

from edge_client.contract.backoff import UNTIL_THE_CAP, after_failures
from sms.level2.inner import InnerCommandTable
from sms.models import Outcome, SmsMessage
from sms.modem import Modem, ModemError, PinRequired, ReceivedSms, SendUnconfirmed, receive_all
from sms.services import (
    sms_handle_incoming,
    sms_mark_failed,
    sms_mark_sent,
    sms_outgoing_pending,
    sms_replies_due,
)
from vessels.models import Vessel

log = logging.getLogger(__name__)

# One wait for +CMTI, and the port's read timeout: bounds how late a nudged reply starts (issue
# 11: the C&C's ACK → the reply handed to the modem ≤ 100 ms). An idle pass costs one select().
POLL_S = 0.01
# Without a nudge, held and pending replies are looked at this often (retry times, windows),
# and close_old_connections() runs.
HOUSEKEEPING_S = 1.0
RETRY_BASE_S = 5.0  # first wait after a temporary send failure; doubles
RETRY_MAX_S = 300.0
MAX_ATTEMPTS = 8  # ~20 min of doubling waits: a reply older than that has lost its point
PERMANENT_PAUSE_S = 10.0  # the modem refused for good (SIM PIN): look again this much later
DATABASE_PAUSE_S = 1.0


class SmsLink:
    """Receive, hold, release and send the SMS of one vessel through one modem."""

    def __init__(
        self,
        *,
        vessel: Vessel,
        modem: Modem,
        reply_window_s: float = 0.0,
        readings: Callable[[], Mapping[str, float]] | None = None,
        refresh: Callable[[], object] | None = None,
        table: InnerCommandTable | None = None,
        poll_s: float = POLL_S,
        retry_base_s: float = RETRY_BASE_S,
        retry_max_s: float = RETRY_MAX_S,
        max_attempts: int = MAX_ATTEMPTS,
        now: Callable[[], dt.datetime] = timezone.now,
        clock: Callable[[], float] = time.monotonic,
        shore_key_hash: str | None = None,
    ) -> None:
        self.vessel = vessel
        # The hash of the shore link's key: checks the reference of the shore's command SMS.
        self.shore_key_hash = shore_key_hash
        self.modem = modem
        self.reply_window_s = reply_window_s
        self.readings = readings
        self.refresh = refresh
        self.table = table
        self.poll_s = poll_s
        self.retry_base_s = retry_base_s
        self.retry_max_s = retry_max_s
        self.max_attempts = max_attempts
        self.now = now
        self.clock = clock
        self._attempts: dict[int, int] = {}
        self._retry_at: dict[int, float] = {}
        self._paused_until = 0.0
        self._housekept = 0.0
        self._looked = 0.0
        self._nudged = threading.Event()
        self.received = 0
        self.sent = 0
        self.failed = 0
        self.errors = 0

    # -- the units ------------------------------------------------------------------------------

    def do_one_receive(self, timeout_s: float | None = None) -> bool:
        """Wait up to ``timeout_s`` for the modem's news, then store and delete what arrived."""
        events = self.modem.poll_events(self.poll_s if timeout_s is None else timeout_s)
        done = receive_all(self.modem, self._store, events)
        self.received += done
        return done > 0

    def do_one_replies_due(self) -> bool:
        """Release held replies whose commands ended or whose window passed."""
        return sms_replies_due(vessel=self.vessel, now=self.now()) > 0

    def do_one_send(self) -> bool:
        """Send the oldest pending reply whose retry time has come; True if one was tried."""
        now = self.clock()
        for message in sms_outgoing_pending(vessel=self.vessel):
            if self._retry_at.get(message.pk, 0.0) > now:
                continue
            self._send(message)
            return True
        return False

    def nudge(self) -> None:
        """Something may have changed the replies (a command ended): look at once. Any thread."""
        self._nudged.set()

    # -- the loop -------------------------------------------------------------------------------

    def run(self, stop: threading.Event) -> None:
        """Loop the units until ``stop``; the modem stays open between them."""
        try:
            while not stop.is_set():
                self.step(stop)
        finally:
            self.modem.close()
            connection.close()  # this thread's own connection

    def step(self, stop: threading.Event) -> None:
        """One pass: news from the modem, held replies, every pending reply that is due."""
        if self.clock() < self._paused_until:
            stop.wait(min(self.poll_s * 10, self._paused_until - self.clock()))
            return
        try:
            received = self.do_one_receive()
            if received or self._nudged.is_set() or self.clock() - self._looked >= HOUSEKEEPING_S:
                self._nudged.clear()
                self._looked = self.clock()
                self.do_one_replies_due()
                while not stop.is_set() and self.do_one_send():
                    pass
        except ModemError as exc:
            self.errors += 1
            if exc.permanent:
                log.error("modem: %s; trying again in %.0f s", exc, PERMANENT_PAUSE_S)
                self._paused_until = self.clock() + PERMANENT_PAUSE_S
            else:
                log.warning("modem: %s", exc)  # the driver backs off and recovers by itself
        except DatabaseError as exc:
            self.errors += 1
            log.warning("database: %s; reconnecting", exc)
            connection.close()
            self._paused_until = self.clock() + DATABASE_PAUSE_S
        except Exception:  # noqa: BLE001 - the modem thread must outlive any one failure
            self.errors += 1
            log.exception("modem link failed; reopening the modem")
            self.modem.close()
            self._paused_until = self.clock() + DATABASE_PAUSE_S
        if self.clock() - self._housekept >= HOUSEKEEPING_S:
            self._housekept = self.clock()
            close_old_connections()

    # -- helpers --------------------------------------------------------------------------------

    def _store(self, sms: ReceivedSms) -> None:
        if self.refresh is not None:
            self.refresh()  # the glider's latest fix written first: #STATUS gives it
        result = sms_handle_incoming(
            vessel=self.vessel,
            number=sms.number,
            text=sms.text,
            received_at=self.now(),
            modem_timestamp=sms.timestamp,
            table=self.table,
            reply_window_s=self.reply_window_s,
            readings=self.readings() if self.readings else None,
            shore_key_hash=self.shore_key_hash,
        )
        seen = " (seen before)" if result.duplicate else ""
        if result.outcome == Outcome.STRANGER:
            # A stranger's text is someone else's business: the SMS log in the database keeps
            # it for the operators; the bridge's log says only who and what became of it.
            log.info("SMS in from %s: %s%s", sms.number, result.outcome, seen)
            log.debug("SMS in from %s (stranger): %r", sms.number, sms.text)
        else:
            log.info("SMS in from %s: %r: %s%s", sms.number, sms.text, result.outcome, seen)

    def _send(self, message: SmsMessage) -> None:
        try:
            reference = self.modem.send(message.number, message.text)
        except PinRequired:
            raise  # the modem's trouble, not this message's: step() pauses the link
        except SendUnconfirmed as exc:
            log.warning("SMS to %s went out unconfirmed: %s", message.number, exc)
            sms_mark_sent(
                message=message, reference="", now=self.now(), detail=f"unconfirmed: {exc}"
            )
            self._forget(message.pk)
            self.sent += 1
        except ModemError as exc:
            attempts = self._attempts.get(message.pk, 0) + 1
            if exc.permanent or attempts >= self.max_attempts:
                why = str(exc) if exc.permanent else f"gave up after {attempts} attempts: {exc}"
                log.warning("SMS to %s failed: %s", message.number, why)
                sms_mark_failed(message=message, reason=why, now=self.now())
                self._forget(message.pk)
                self.failed += 1
                return
            wait = after_failures(
                self.retry_base_s, attempts - 1, cap=self.retry_max_s, max_doublings=UNTIL_THE_CAP
            )
            log.warning("SMS to %s not sent (%s); again in %.0f s", message.number, exc, wait)
            self._attempts[message.pk] = attempts
            self._retry_at[message.pk] = self.clock() + wait
        else:
            sms_mark_sent(message=message, reference=reference or "", now=self.now())
            log.info("SMS out to %s (ref %s): %s", message.number, reference, message.text)
            self._forget(message.pk)
            self.sent += 1

    def _forget(self, pk: int) -> None:
        self._attempts.pop(pk, None)
        self._retry_at.pop(pk, None)
