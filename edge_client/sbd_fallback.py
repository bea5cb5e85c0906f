"""The boat's side of the SBD fallback link: the ``sbd`` thread of the edge client.

HTTP is the link; Iridium SBD costs per message, so it is used only

- while HTTP has been failing for more than ``[sbd] fallback_after_s``: every ``period_s``
  one mobile-originated (MO) message with the newest fixes of the outbox, compact, as many as
  fit in 340 bytes. The fixes stay queued: HTTP delivers them again when it returns and the
  shore counts each (vessel, time) once. Fixes already sent by SBD are not sent by SBD again;
- when the modem rings (``SBDRING``: the shore put a message, an urgent command, at the
  gateway), at once, whatever HTTP does: a mailbox check, or the fallback's message if one is
  due anyway. With ``mailbox_check`` the messages still waiting are fetched too.

A mobile-terminated (MT) message is a command in the compact command form
(``edge_client/contract/compact_command.py``): it goes to the executor exactly as a polled one,
deduplicated by its uid (a command that also comes by HTTP runs once); its acks go through the
outbox and HTTP. Anything else is logged and dropped. The modem's failures never end the
client: a temporary one is tried again a minute later, a permanent ``SessionFailed`` (no
subscription, antenna fault) ends SBD use with one error in the log.

The choice of fixes (:func:`pick_fixes`), when a session is due (:func:`fallback_due`) and the
reading of an MT message (:func:`command_from_mt`) are pure; :class:`SbdFallback` does the I/O.
"""

from __future__ import annotations

import datetime as dt
import logging
import threading
import time
from collections.abc import Callable, Sequence

from edge_client.commands import Command
from edge_client.config import SbdLinkConfig
from edge_client.contract import compact, compact_command
from edge_client.outbox import Item, Outbox
from edge_client.sbd import MO_MAX, SbdConfig, SbdError, SbdModem, SessionFailed, SessionResult

log = logging.getLogger(__name__)

# Fixes read from the outbox for one message: more than any 340 bytes can hold (a boat at
# anchor on a steady period costs about 2 bytes a fix).
CANDIDATES = 400
# A failed session (no sky, a modem that does not answer) is tried again this much later;
# the driver has already retried it with its own backoff.
RETRY_S = 60.0
# How often the thread looks at the stop flag and at HTTP's state while it waits for a ring.
TICK_S = 0.25
# Mailbox checks after a session that said more MT messages wait, at most (each costs).
MAX_FOLLOW_UPS = 5


class Stopping(Exception):
    """The client is stopping: ends a session's backoff wait (raised by the driver's sleep)."""


def fallback_due(
    failing_for: float | None, since_last: float | None, config: SbdLinkConfig
) -> bool:
    """Whether the fallback's message is due: HTTP failing (``failing_for`` seconds, None when
    it works) for more than ``fallback_after_s``, and ``period_s`` since the last session
    (``since_last``; None: none yet)."""
    if failing_for is None or failing_for <= config.fallback_after_s:
        return False
    return since_last is None or since_last >= config.period_s


def pick_fixes(
    items: Sequence[Item], channels: Sequence[compact.Channel], max_bytes: int = MO_MAX
) -> tuple[bytes, list[Item]] | None:
    """The newest fixes (``items`` newest first) that fit ``max_bytes`` as one compact payload:
    (payload, the items in the payload's order), or None if not one fits. A fix the compact
    form refuses is left out (HTTP carries it as JSON); readings outside ``channels`` too."""
    usable = [item for item in items if _encodable(item, channels)]
    if not usable:
        return None
    # Each fix adds bytes (a few bits at the least), so the largest count that fits is found
    # by halving; the check after it covers a payload the prediction made one byte longer.
    low, high = 0, len(usable)
    while low < high:
        mid = (low + high + 1) // 2
        if len(_encode(usable[:mid], channels)[0]) <= max_bytes:
            low = mid
        else:
            high = mid - 1
    while low > 0:
        payload, ordered = _encode(usable[:low], channels)
        if len(payload) <= max_bytes:
            return payload, ordered
        low -= 1
    return None


def _encode(items: Sequence[Item], channels: Sequence[compact.Channel]) -> tuple[bytes, list[Item]]:
    ordered = [items[k] for k in compact.payload_order([i.body for i in items])]
    return compact.encode([i.body for i in ordered], channels, drop_unknown=True), ordered


def _encodable(item: Item, channels: Sequence[compact.Channel]) -> bool:
    try:
        compact.encode([item.body], channels, drop_unknown=True)
    except compact.CompactError as exc:
        log.debug("fix %d cannot go compact by SBD: %s", item.id, exc)
        return False
    return True


def sent_times(payload: bytes, channels: Sequence[compact.Channel]) -> list[int]:
    """The fix times (Unix seconds) a payload carries, in its order."""
    return [
        int(dt.datetime.fromisoformat(fix["time"].replace("Z", "+00:00")).timestamp())
        for fix in compact.decode(payload, channels)
    ]


def command_from_mt(data: bytes) -> Command:
    """The command an MT message carries; ValueError (CompactCommandError) if it is none.
    Parameters left out are absent, as in a polled command."""
    wire = compact_command.decode(data)
    params = {name: value for name, value in wire.params.items() if value is not None}
    return Command(uid=wire.uid, kind=wire.kind, params=params)


class SbdFallback:
    """The ``sbd`` thread: owns the modem (the driver is not thread-safe)."""

    def __init__(
        self,
        config: SbdLinkConfig,
        channels: Sequence[compact.Channel],
        outbox: Outbox,
        *,
        failing_for: Callable[[float], float | None],
        on_command: Callable[[Command], bool],
        stop: threading.Event,
        modem: SbdModem | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.config = config
        self.channels = tuple(channels)
        self.outbox = outbox
        self.failing_for = failing_for
        self.on_command = on_command
        self.stop_event = stop
        self.clock = clock
        self.modem = modem or SbdModem(
            SbdConfig(config.port, baudrate=config.baudrate, ring_alerts=config.mailbox_check),
            sleep=self._sleep,
        )
        self.disabled = False  # a permanent failure: no more SBD until a restart
        self.sessions = 0  # successful ones
        self._last_session: float | None = None
        self._retry_at = 0.0
        self._sent_up_to = 0  # the newest outbox id sent by SBD: not sent by SBD again
        self._failing_logged = False
        self._thread: threading.Thread | None = None

    # -- the thread ---------------------------------------------------------------------------

    def start(self) -> None:
        self._thread = threading.Thread(target=self.run, name="sbd", daemon=True)
        self._thread.start()

    def join(self, timeout: float) -> None:
        if self._thread is not None:
            self._thread.join(timeout)

    def is_alive(self) -> bool:
        """Running, or ended for good by a permanent failure (which is not a fault of ours)."""
        return self.disabled or (self._thread is not None and self._thread.is_alive())

    def run(self) -> None:
        log.info("SBD modem on %s: the fallback link", self.config.port)
        try:
            while not self.stop_event.is_set() and not self.disabled:
                try:
                    self.step()
                except Stopping:
                    return
                except Exception:  # a bug or a broken outbox must not end the thread for good
                    log.exception("SBD round failed")
                    self._retry_at = self.clock() + RETRY_S
        finally:
            self.modem.close()

    def step(self) -> None:
        """Wait a moment for a ring, and run a session if one is due."""
        now = self.clock()
        if now < self._retry_at:
            self.stop_event.wait(min(TICK_S, self._retry_at - now))
            return
        if self._fallback_due(now):
            self.session()
            return
        if not self.config.mailbox_check:
            self.stop_event.wait(TICK_S)
            return
        try:
            ring = self.modem.wait_for_ring(TICK_S)
        except SbdError as exc:
            self._failed(exc)
            return
        if ring:
            log.info("SBD ring alert: a message from the shore waits at the gateway")
            self.session()

    def session(self) -> None:
        """One session: the fallback's message if HTTP is failing, else a mailbox check; then
        the MT messages it brings. A failure is logged and tried again later."""
        now = self.clock()
        picked = None
        fallback = self._in_fallback(now)
        if fallback:
            items = self.outbox.newest("fix", CANDIDATES, after_id=self._sent_up_to)
            picked = pick_fixes(items, self.channels)
            if picked is None and not self.config.mailbox_check and not self.modem.ring_pending:
                log.info("SBD: no new fixes to send")
                self._last_session = now
                return
        if picked is not None:
            # The shore keeps whole seconds from this message, and HTTP must bring the same
            # times: rewritten before the session (a minute, at times), not after it, so an
            # uplink round that posts these fixes meanwhile already sends the SBD times.
            payload, items = picked
            times = sent_times(payload, self.channels)
            self.outbox.set_fix_times([(i.id, t) for i, t in zip(items, times, strict=True)])
        try:
            result = self.modem.exchange(picked[0] if picked else None)
            if fallback:
                self._last_session = now  # one message a period; a failed one is tried again
            if picked is not None and result.mo_sent:
                self._sent(*picked, result)
            self._received(result)
            follow_ups = 0
            while self.config.mailbox_check and result.mt_queued and follow_ups < MAX_FOLLOW_UPS:
                follow_ups += 1
                result = self.modem.exchange(None)
                self._received(result)
        except SessionFailed as exc:
            if not exc.permanent:
                self._failed(exc)
                return
            log.error("SBD disabled until the client restarts: %s", exc)
            self.disabled = True
        except SbdError as exc:
            self._failed(exc)
        else:
            if self._failing_logged:
                log.info("SBD modem works again")
            self._failing_logged = False

    # -- pieces -------------------------------------------------------------------------------

    def _in_fallback(self, now: float) -> bool:
        failing = self.failing_for(now)
        return failing is not None and failing > self.config.fallback_after_s

    def _fallback_due(self, now: float) -> bool:
        since = None if self._last_session is None else now - self._last_session
        return fallback_due(self.failing_for(now), since, self.config)

    def _sent(self, payload: bytes, items: list[Item], result: SessionResult) -> None:
        self.sessions += 1
        self.outbox.bump("sbd_messages")
        self._sent_up_to = max(self._sent_up_to, *(item.id for item in items))
        log.info(
            "SBD: sent %d fixes in %d bytes (MOMSN %d); they stay queued for HTTP",
            len(items),
            len(payload),
            result.momsn,
        )

    def _received(self, result: SessionResult) -> None:
        if result.mt_lost:
            log.warning("SBD: a message from the shore came but could not be read off the modem")
        if result.mt is None:
            return
        try:
            command = command_from_mt(result.mt)
        except ValueError as exc:
            log.warning(
                "SBD: dropping a message from the shore that is no command (%s): %s",
                exc,
                result.mt[:64].hex(),
            )
            self.outbox.bump("sbd_dropped_mt")
            return
        if self.on_command(command):
            log.info("command %s (%s) came by SBD", command.uid, command.kind)
        else:
            log.info("command %s came by SBD again; already taken", command.uid)

    def _failed(self, exc: SbdError) -> None:
        self._retry_at = self.clock() + RETRY_S
        if not self._failing_logged:
            log.warning("SBD modem failed: %s; trying again in %.0f s", exc, RETRY_S)
        else:
            log.debug("SBD modem failed again: %s", exc)
        self._failing_logged = True

    def _sleep(self, seconds: float) -> None:
        """The driver's backoff between failed sessions: cut short by the stop flag."""
        if self.stop_event.wait(seconds):
            raise Stopping()
