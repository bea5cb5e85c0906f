"""The edge client's main loop: sample → outbox → uplink, poll → executor.

Threads and what each owns:

- ``mavlink-reader`` (:class:`MavlinkLink`): receives MAVLink, keeps the vehicle state;
- ``executor`` (:class:`Executor`): runs commands (arming can take a minute; a mission upload
  several seconds) without holding up telemetry;
- ``uplink``: the only thread that talks to the server: sends queued acks, then fixes in
  batches, then polls for commands unless a telemetry answer already carried their list (one
  exchange per period). A slow or absent server delays only this thread;
- ``sbd`` (:class:`SbdFallback`, only with ``[sbd] port``): the only thread that talks to the
  Iridium SBD modem: the newest fixes by SBD while HTTP keeps failing, commands from the shore
  when the modem rings (sbd_fallback.py);
- the caller's thread (:meth:`EdgeClient.run`): every telemetry period puts a fix into the
  outbox, pings the systemd watchdog while the other threads are alive, and watches the stop
  flag that SIGTERM sets.

Stopping flushes almost nothing: acks and command records are committed at once, and fixes
waiting for their group commit are committed when the outbox is closed, so the shutdown only
stops threads (an in-flight request is abandoned; its items stay queued).
"""

from __future__ import annotations

import logging
import sqlite3
import threading
import time
from collections.abc import Callable

from edge_client import systemd
from edge_client.commands import Command
from edge_client.config import Config
from edge_client.contract import exchange
from edge_client.contract.backoff import after_failures
from edge_client.contract.status import Status
from edge_client.executor import Executor
from edge_client.fix_upload import TELEMETRY_PATH, post_fixes  # noqa: F401 (shore.py, cli.py)
from edge_client.mavlink_link import MavlinkLink
from edge_client.outbox import Item, Outbox, settle_fix_batch
from edge_client.sbd_fallback import SbdFallback
from edge_client.transports.base import Transport, TransportError

log = logging.getLogger(__name__)

COMMANDS_PATH = "/api/v1/boat/commands/"
ACK_PATH = "/api/v1/boat/commands/{uid}/ack/"
MAX_OUTAGE_BACKOFF_S = 60.0
# A round put off for the next fix runs this long after the fix is due (its sample and commit,
# a busy Pi's late wake-up), or a quarter of the telemetry period if that is longer.
FIX_GRACE_S = 0.2
# Ack answers that will never change (docs/api.md#errors): unknown/other vessel's command, illegal
# transition (cancelled meanwhile), malformed.
ACK_DROP_STATUSES = frozenset({400, 404, 409})
# An older server knows no `superseded` ack (400): the command is then acked `failed` with the
# same detail, so that it does not stay open there.
SUPERSEDED, FAILED = Status.SUPERSEDED, Status.FAILED


def post_ack(transport: Transport, outbox: Outbox, item: Item) -> None:
    """Send one queued ack and take it out of the outbox.

    An ack the server will never take (ACK_DROP_STATUSES) is dropped and counted
    (``dropped_acks``); any other transport error propagates and the ack stays queued.
    A ``superseded`` ack that the server refuses with 400 (a server from before that status)
    is sent again as ``failed``, so that the command does not stay open there.
    The edge client and the glider's shore link both send their acks through here.
    """
    body = item.body
    path = ACK_PATH.format(uid=body["uid"])
    try:
        try:
            transport.post_json(path, {"status": body["status"], "detail": body["detail"]})
        except TransportError as exc:
            if not (body["status"] == SUPERSEDED and exc.permanent and exc.status == 400):
                raise
            log.info("server takes no superseded ack (%s); sending %s as failed", exc, body["uid"])
            transport.post_json(path, {"status": FAILED, "detail": body["detail"]})
    except TransportError as exc:
        if not (exc.permanent and exc.status in ACK_DROP_STATUSES):
            raise
        log.warning(
            "server will never take ack %s %s (%s); dropping it", body["uid"], body["status"], exc
        )
        outbox.bump("dropped_acks")
    outbox.remove([item.id])


class EdgeClient:
    def __init__(
        self,
        config: Config,
        *,
        transport: Transport,
        link: MavlinkLink,
        outbox: Outbox,
        stop: threading.Event | None = None,
    ) -> None:
        self.config = config
        self.transport = transport
        self.link = link
        self.outbox = outbox
        self.stop_event = stop or threading.Event()
        self._kick = threading.Event()
        self.executor = Executor(link, outbox, config.commands, on_ack=self._kick.set)
        self.etag: str | None = None
        self.exchange = config.commands.exchange
        self.server_ok: bool | None = None
        self._uplink: threading.Thread | None = None
        self._failures = 0
        self._next_poll = 0.0
        # This round's telemetry answer said the command list is current (exchange.py).
        self._list_current = False
        # When the last fix went into the outbox (monotonic), and whether the poll now due was
        # already put off once to wait for the next one.
        self._sampled_at: float | None = None
        self._waited_for_fix = False
        # Since when HTTP fails (monotonic): the last good exchange, or the first failed one
        # when none has worked since the start. None while it works.
        self._last_ok_at: float | None = None
        self._failing_since: float | None = None
        self.sbd: SbdFallback | None = None
        if config.sbd.port:
            self.sbd = SbdFallback(
                config.sbd,
                config.telemetry.channels,
                outbox,
                failing_for=self.http_failing_for,
                on_command=self.take_command,
                stop=self.stop_event,
            )

    # -- the main thread ----------------------------------------------------------------------

    def run(self, on_ready: Callable[[], None] | None = None) -> int:
        """Run until the stop flag is set. Returns the process exit status."""
        self.executor.recover()
        self.link.start()
        self.executor.start()
        self._uplink = threading.Thread(target=self._uplink_loop, name="uplink", daemon=True)
        self._uplink.start()
        if self.sbd is not None:
            self.sbd.start()
        systemd.ready(f"talking to {self.config.mavlink.connection}")
        log.info(
            "edge client ready: %s -> %s (%s transport)",
            self.config.mavlink.connection,
            self.config.server.url,
            self.config.transport.kind,
        )
        if on_ready:
            on_ready()
        watchdog_every = systemd.watchdog_interval()
        next_sample = time.monotonic()
        next_watchdog = 0.0
        warned_no_fix = False
        try:
            while not self.stop_event.is_set():
                now = time.monotonic()
                if now >= next_sample:
                    next_sample = max(next_sample + self.config.telemetry.period_s, now)
                    try:
                        warned_no_fix = self.sample(warned_no_fix)
                    except sqlite3.Error as exc:  # disk full, card failing: log, keep running
                        log.error("cannot store a fix in the outbox: %s", exc)
                if watchdog_every and now >= next_watchdog and self.healthy():
                    systemd.watchdog()
                    next_watchdog = now + watchdog_every
                self.stop_event.wait(min(0.2, max(0.0, next_sample - time.monotonic())))
        finally:
            self.shutdown()
        return 0

    def sample(self, warned: bool = False) -> bool:
        """Put the current fix into the outbox. Returns True while there is no fix to record."""
        fix = self.link.state.fix()
        if fix is None:
            if not warned:
                log.warning("no current position from the autopilot; not recording fixes")
            return True
        if warned:
            log.info("position from the autopilot again; recording fixes")
        evicted_total = self.outbox.counter("evicted_fixes")
        if evicted_total:
            fix["readings"]["edge_evicted_fixes"] = evicted_total  # reported to the shore
        self.outbox.add_fix(fix)
        self._sampled_at = time.monotonic()
        return False

    def healthy(self) -> bool:
        return (
            self.link.is_alive()
            and self.executor.is_alive()
            and self._uplink is not None
            and self._uplink.is_alive()
            and (self.sbd is None or self.sbd.is_alive())
        )

    def shutdown(self) -> None:
        log.info("stopping")
        systemd.stopping()
        self.stop_event.set()
        self._kick.set()
        self.executor.stop()
        if self._uplink is not None:
            # An in-flight request is bounded by the transport timeout; its items stay queued.
            self._uplink.join(timeout=5)
        if self.sbd is not None:
            # A session under way is bounded by the modem's timeout; its wait is cut short.
            self.sbd.join(timeout=5)
        self.link.stop()
        self.transport.close()
        log.info(
            "stopped; %d fixes and %d acks queued",
            self.outbox.count("fix"),
            self.outbox.count("ack"),
        )

    # -- the uplink thread --------------------------------------------------------------------

    def _uplink_loop(self) -> None:
        while not self.stop_event.is_set():
            # Cleared before the round, so an ack queued during it wakes the next one at once.
            self._kick.clear()
            try:
                wait = self.uplink_once(time.monotonic())
            except Exception:  # a bug or a broken outbox must not end the uplink for good
                log.exception("uplink round failed")
                wait = MAX_OUTAGE_BACKOFF_S
            self._kick.wait(wait)

    def uplink_once(self, now: float) -> float:
        """One round: acks, fixes, poll if due. Returns how long to wait before the next round.

        A round whose telemetry answer carried the command list's state (one exchange per
        period, docs/api.md) polls not, and puts the next poll a period off: a boat that
        reports every period never polls; one with nothing to send polls as ever."""
        period = self.config.commands.poll_period_s
        self._list_current = False
        try:
            self.flush_acks()
            self.flush_fixes()
            if self._list_current:
                self._next_poll = now + period
                self._waited_for_fix = False
            elif now >= self._next_poll and (fix_at := self._fix_coming(now)) is not None:
                self._next_poll = fix_at
                self._waited_for_fix = True
            elif now >= self._next_poll:
                self.poll()
                self._next_poll = now + period
                self._waited_for_fix = False
        except TransportError as exc:
            self._failures += 1
            self._report(False, exc)
            return after_failures(period, self._failures, cap=MAX_OUTAGE_BACKOFF_S)
        self._failures = 0
        self._report(True)
        return max(0.05, min(period, self._next_poll - time.monotonic()))

    def _fix_coming(self, now: float) -> float | None:
        """When to run the round instead of polling now, or None to poll.

        A boat reporting every round whose round came just before its next fix (the sampling
        and the uplink run on clocks of their own; at equal periods they drift past each
        other) waits for that fix, once, rather than poll: the fix's exchange brings the list.
        Only while fixes come at least once a poll period, so the list is never older than a
        poll period and one telemetry period."""
        telemetry = self.config.telemetry.period_s
        if not self.exchange or self._waited_for_fix or self._sampled_at is None:
            return None
        if telemetry > self.config.commands.poll_period_s or now - self._sampled_at >= telemetry:
            return None
        return self._sampled_at + telemetry + max(FIX_GRACE_S, telemetry / 4)

    def http_failing_for(self, now: float) -> float | None:
        """How long (s) HTTP has been failing at ``now`` (monotonic), None while it works."""
        since = self._failing_since
        return None if since is None else max(0.0, now - since)

    def _report(self, ok: bool, exc: TransportError | None = None) -> None:
        now = time.monotonic()
        if ok:
            self._last_ok_at, self._failing_since = now, None
        elif self._failing_since is None:
            self._failing_since = self._last_ok_at if self._last_ok_at is not None else now
        if ok and self.server_ok is not True:
            log.info("server reachable; %d fixes queued", self.outbox.count("fix"))
        elif not ok and self.server_ok is not False:
            if exc is not None and exc.status in (401, 403):
                log.error(
                    "the server refused the vessel key (HTTP %s); check [server] key", exc.status
                )
            else:
                log.warning("server unreachable: %s; fixes stay queued", exc)
        self.server_ok = ok

    def flush_acks(self) -> None:
        for item in self.outbox.peek("ack", 50):
            post_ack(self.transport, self.outbox, item)

    def flush_fixes(self) -> None:
        batch_size = self.config.telemetry.batch_size
        while not self.stop_event.is_set():
            items = self.outbox.peek("fix", batch_size)
            if not items:
                return
            if not self._send_fixes(items) or len(items) < batch_size:
                # Less than a batch: the outbox was drained when read. A fix sampled since
                # waits for the next round rather than cost a request of its own.
                return

    def _send_fixes(self, items: list) -> bool:
        """POST one batch; True if every fix in it was settled (so the caller may go on)."""
        headers = (
            {
                exchange.HEADER: exchange.held_etag(self.etag),
                exchange.PREFER_HEADER: exchange.PREFER,
            }
            if self.exchange
            else None
        )
        try:
            sent, response = post_fixes(self.transport, items, self.config.telemetry, headers)
        except TransportError as exc:
            if exc.status != 400:
                raise
            # "Whole body malformed": one poisoned fix must not block the rest. Split until it
            # is alone, then drop it.
            if len(items) == 1:
                log.warning(
                    "server refuses fix %s as malformed (%s); dropping it", items[0].body, exc
                )
                self.outbox.bump("rejected_fixes")
                self.outbox.remove([items[0].id])
                return True
            half = len(items) // 2
            return self._send_fixes(items[:half]) and self._send_fixes(items[half:])
        if self.exchange and response.status == exchange.SETTLED:
            # Every fix stored or already there, and the list held is current.
            self._list_current = True
            self.outbox.remove([i.id for i in sent])
            return True
        answer = response.json()
        if self.exchange:
            self._take_exchange(answer)
        settlement = settle_fix_batch([i.id for i in sent], answer)
        if settlement.keep_reason:
            log.warning("keeping %d fixes: %s", len(sent), settlement.keep_reason)
            return False
        for fix_id, errors in settlement.rejected:
            log.warning("server rejected fix %d: %s; dropping it", fix_id, errors)
        if settlement.rejected:
            self.outbox.bump("rejected_fixes", len(settlement.rejected))
        self.outbox.remove(settlement.remove)
        return True

    def _take_exchange(self, answer: object) -> None:
        """The command list a telemetry answer carries, as a poll's: an answer without one
        (an older server) leaves the poll to do it."""
        found = exchange.list_in_answer(answer)
        if found is None:
            return
        etag, commands = found
        if commands is not None:
            self._take_commands(commands)
        self.etag = etag
        self._list_current = True

    def poll(self) -> None:
        response = self.transport.get(COMMANDS_PATH, self.etag)
        if response.status == 304:
            return
        data = response.json()
        commands = data.get("commands") if isinstance(data, dict) else None
        if not isinstance(commands, list):
            raise TransportError("commands answer has no commands list")
        self._take_commands(commands)
        self.etag = response.etag

    def _take_commands(self, commands: list) -> None:
        new = self.executor.offer(commands)
        if new:
            log.info("%d new command(s) from the server", new)

    def take_command(self, command: Command) -> bool:
        """A command from another link (SBD): run unless its uid came before, by any link."""
        return self.executor.offer_command(command)
