"""The glider's link to a shore Shoreside (issue 11 §6, docs/wave-glider.md).

On the glider the bridge runs with a local database: the glider is its own little Shoreside.
When an upstream URL and a vessel key are configured it is also a vessel of a shore Shoreside,
through the boat API like any boat:

- fixes (with their readings) go up from the local database. The local database is the store:
  a watermark (the last local Fix id the shore answered for) is kept in the edge client's
  outbox file, so nothing is lost while the link is down and a re-send after a crash is a
  duplicate on the shore (unique vessel + recorded_at);
- the vessel's shore commands are polled with an ETag and queued locally under the *same uid*
  (``commands.services.command_enqueue``), so a re-poll never queues one twice and the Level 2
  source hands them to the C&C like SMS commands (a uid held here already as another command,
  one an SMS under that uid said, is not taken for it: the shore's is acked ``failed``); their
  progress goes back as acks through the outbox (``acknowledged`` once handed to the C&C, then
  ``done``/``failed`` with the detail; a command superseded here is ``superseded`` there, one
  cancelled or expired ``failed``), which survives outages and restarts. The outbox's command
  table remembers which shore uids are still running here;
- the authorised numbers are fetched with an ETag and replace the local list for this vessel
  (``sms.services.authorised_numbers_replace``); while the shore is away the last list stays;
- the commands created here (by SMS, or the glider's own admin) are reported up as they stand
  (``POST boat/commands/report/``) whenever one of their events is past a third watermark (the
  last local CommandEvent id reported), so the shore mirrors each status change; a re-send is
  a duplicate there; a report refused whole (404/405, a 400, a shore that is down) is kept and
  the link backs off. Shore commands (``created_by`` == :data:`CREATED_BY`) are not reported:
  their acks carry their state;
- the SMS log goes up in id order behind a second watermark (an outgoing SMS still waiting for
  the modem is held back for a while, so that the shore gets its real send status). The
  command report's backlog goes first, so the shore links each SMS to the commands it made.

Each ``do_one_<thing>()`` is one small unit of work returning True if it got something done;
:meth:`ShoreLink.do_one` runs the ones that are due and :meth:`ShoreLink.run` loops in a thread
of its own. No failure here ever reaches the caller: a transport failure is logged once and
the link backs off (doubling up to ``max_backoff_s``), and SMS control carries on without it.
Transport and outbox are the edge client's (``edge_client.transports``, ``edge_client.outbox``).
"""

from __future__ import annotations

import datetime as dt
import logging
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from django.conf import settings
from django.core.exceptions import ValidationError
from django.db import DatabaseError, IntegrityError, close_old_connections, connections
from django.utils import timezone

from audit.context import audit_origin
from commands.errors import CatalogError, CommandError
from commands.lifecycle import FINAL, Status
from commands.models import Source
from commands.services import command_enqueue, command_withdraw_queued
from edge_client.client import COMMANDS_PATH, TELEMETRY_PATH, post_ack
from edge_client.contract.backoff import after_failures
from edge_client.outbox import Outbox, settle_fix_batch
from edge_client.transports.base import Transport, TransportError
from edge_client.transports.http import HttpTransport
from sms import selectors
from sms.bridge.shore_config import ShoreConfig
from sms.bridge.shore_wire import command_report_wire, sms_wire, when
from sms.command_text import SHORE_CREATED_BY, same_command
from sms.models import Direction, SendStatus, SmsMessage
from sms.services import authorised_numbers_replace
from sms.services.shore import SHORE_ORIGIN
from telemetry.models import Fix
from telemetry.services import fix_summary
from vessels.models import Vessel

log = logging.getLogger(__name__)

# Replies whose send status is still to come: queued for the modem, or held for the C&C's answer.
UNSETTLED = (SendStatus.PENDING, SendStatus.WAITING)

NUMBERS_PATH = "/api/v1/boat/numbers/"
SMS_PATH = "/api/v1/boat/sms/"
REPORT_PATH = "/api/v1/boat/commands/report/"
# The shore takes at most this many commands per report (commands.api.boat).
REPORT_MAX_BATCH = 200
# Report batches sent before an SMS upload; more backlog than that, and the SMS waits a round.
REPORT_BEFORE_SMS_MAX = 10
# A local command queued from the shore (polled, or texted with its reference): created_by
# and event actor.
CREATED_BY = SHORE_CREATED_BY
FIX_WATERMARK = "shore_fix_watermark"  # outbox counters: the last local Fix id settled
SMS_WATERMARK = "shore_sms_watermark"  # the last local SmsMessage id uploaded
REPORT_WATERMARK = "shore_report_watermark"  # the last local CommandEvent id reported
# The last local Command id looked at among the shore's commands that came by SMS.
SMS_COMMAND_WATERMARK = "shore_sms_command_watermark"
OUTBOX_NAME = "wg-shore-outbox.sqlite3"
HANDED_OVER = (Status.SENT, Status.ACKNOWLEDGED)  # local statuses acked as "acknowledged"
# Final local statuses that are ack statuses on the shore too; the others are acked "failed".
ACKED_AS_IS = (Status.DONE, Status.FAILED, Status.SUPERSEDED)


@dataclass
class _Step:
    run: Callable[[], bool]
    period_s: float
    needs_link: bool = True
    due: float = 0.0


@dataclass
class LinkState:
    """What an operator (or a test) wants to know about the link."""

    reachable: bool | None = None  # None: not tried yet
    failures: int = 0
    down_until: float = 0.0
    last_error: str = ""
    numbers_synced_at: dt.datetime | None = None
    counts: dict[str, int] = field(default_factory=dict)


class ShoreLink:
    """The glider side of the shore link for one vessel (see the module docstring).

    ``transport`` and ``outbox`` default to the edge client's HTTP transport (TLS verified,
    against ``ca_bundle`` if given) and an outbox at ``config.outbox_path``.
    """

    def __init__(
        self,
        *,
        vessel: Vessel,
        config: ShoreConfig,
        transport: Transport | None = None,
        outbox: Outbox | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.vessel = vessel
        self.config = config
        # retries=0: the link's own backoff decides when to try again, without sleeping here.
        self.transport = transport or HttpTransport(
            base_url=config.url,
            key=config.key,
            timeout_s=config.timeout_s,
            retries=0,
            ca_bundle=config.ca_bundle,
        )
        if outbox is None:
            outbox = Outbox(config.outbox_path or Path(settings.DATA_DIR) / OUTBOX_NAME)
        self.outbox = outbox
        self.clock = clock
        self.state = LinkState()
        self.commands_etag: str | None = None
        self.numbers_etag: str | None = None
        self._handed_over_acked: set[str] = set()
        # Shore uids held here as another command, acked failed once (see _held_as_polled).
        self._mismatched: set[str] = set()
        self._closed = False
        self._steps = [
            _Step(self.do_one_report_results, config.push_period_s, needs_link=False),
            _Step(self.do_one_flush_acks, config.push_period_s),
            _Step(self.do_one_push_fixes, config.push_period_s),
            _Step(self.do_one_poll_commands, config.poll_period_s),
            _Step(self.do_one_report_commands, config.push_period_s),
            _Step(self.do_one_sync_numbers, config.numbers_period_s),
            _Step(self.do_one_upload_sms, config.sms_period_s),
        ]

    # -- the loop -------------------------------------------------------------------------------

    def do_one(self) -> bool:
        """Run every step that is due; True if any of them got something done. Never raises."""
        worked = False
        for step in self._steps:
            now = self.clock()
            if now < step.due or (step.needs_link and now < self.state.down_until):
                continue
            progressed = self._guarded(step.run)
            # A step with more to do (a backlog) runs again at once; otherwise next period.
            step.due = now if progressed else now + step.period_s
            worked = worked or progressed
        return worked

    def run(self, stop: threading.Event, idle_s: float = 1.0) -> None:
        """Loop until ``stop`` is set (a thread of its own), then close."""
        log.info("shore link to %s for %s", self.config.url, self.vessel.slug)
        try:
            while not stop.is_set():
                close_old_connections()  # a long-lived thread: drop a broken or stale one
                if not self.do_one():
                    stop.wait(idle_s)
        finally:
            self.close()
            connections.close_all()  # this thread's own connection

    def kick(self) -> None:
        """Make every step due now (a test, or the bridge after a power-up)."""
        for step in self._steps:
            step.due = 0.0
        self.state.down_until = 0.0

    def close(self) -> None:
        """Close the transport and the outbox; a second call does nothing."""
        if self._closed:
            return
        self._closed = True
        self.transport.close()
        self.outbox.close()

    def _guarded(self, step: Callable[[], bool]) -> bool:
        try:
            result = step()
        except TransportError as exc:
            self._link_failed(exc)
            return False
        except DatabaseError as exc:
            log.error("shore link: local database: %s", exc)
            return False
        except Exception:  # a bug must not end the link, nor reach the bridge
            log.exception("shore link: %s failed", getattr(step, "__name__", step))
            return False
        return result

    def _link_ok(self) -> None:
        if self.state.reachable is not True:
            log.info("shore %s reachable", self.config.url)
        self.state.reachable = True
        self.state.failures = 0
        self.state.down_until = 0.0

    def _link_failed(self, exc: TransportError) -> None:
        self.state.failures += 1
        wait = after_failures(
            1.0, self.state.failures, cap=self.config.max_backoff_s, max_doublings=16
        )
        self.state.down_until = self.clock() + wait
        self.state.last_error = str(exc)
        if self.state.reachable is not False:
            if exc.status in (401, 403):
                log.error("the shore refused the key (HTTP %s); check WG_SHORE_KEY", exc.status)
            else:
                log.warning("shore unreachable: %s; data stays here until it is back", exc)
        self.state.reachable = False

    def _count(self, name: str, by: int = 1) -> None:
        self.state.counts[name] = self.state.counts.get(name, 0) + by

    def _set_counter(self, name: str, value: int) -> None:
        self.outbox.bump(name, value - self.outbox.counter(name))

    # -- fixes up -------------------------------------------------------------------------------

    def do_one_push_fixes(self) -> bool:
        """Send the next batch of local fixes after the watermark; True if a batch was settled."""
        after = self.outbox.counter(FIX_WATERMARK)
        fixes = selectors.bridge_fixes_after(
            vessel=self.vessel, after=after, limit=self.config.batch_size
        )
        if not fixes:
            return False
        ids = [fix.pk for fix in fixes]
        try:
            response = self.transport.post_json(
                TELEMETRY_PATH, {"fixes": [fix_summary(f) for f in fixes]}
            )
        except TransportError as exc:
            if exc.status != 400:
                raise
            if len(fixes) > 1:  # the body refused whole: go one at a time to find the culprit
                return self._push_one_by_one(fixes)
            log.warning("shore refuses local fix %d (%s); skipping it", ids[0], exc)
            self._set_counter(FIX_WATERMARK, ids[0])
            return True
        self._link_ok()
        settlement = settle_fix_batch(ids, response.json())
        if settlement.keep_reason:
            log.warning("fixes %d–%d stay unsent: %s", ids[0], ids[-1], settlement.keep_reason)
            return False
        for fix_id, errors in settlement.rejected:
            log.warning("shore rejected local fix %d: %s; skipping it", fix_id, errors)
        self._count("fixes_pushed", len(ids) - len(settlement.rejected))
        self._set_counter(FIX_WATERMARK, ids[-1])
        return True

    def _push_one_by_one(self, fixes: list[Fix]) -> bool:
        for fix in fixes:
            try:
                response = self.transport.post_json(TELEMETRY_PATH, {"fixes": [fix_summary(fix)]})
            except TransportError as exc:
                if exc.status != 400:
                    raise
                log.warning("shore refuses local fix %d (%s); skipping it", fix.pk, exc)
            else:
                if settle_fix_batch([fix.pk], response.json()).keep_reason:
                    return False
                self._count("fixes_pushed")
            self._set_counter(FIX_WATERMARK, fix.pk)
        return True

    # -- commands down, acks up -----------------------------------------------------------------

    def do_one_poll_commands(self) -> bool:
        """Poll the shore's commands for this vessel (ETag); queue the new ones here."""
        response = self.transport.get(COMMANDS_PATH, self.commands_etag)
        self._link_ok()
        if response.status == 304:
            return False
        data = response.json()
        commands = data.get("commands") if isinstance(data, dict) else None
        if not isinstance(commands, list):
            raise TransportError("the shore's commands answer has no commands list")
        taken = sum(self._take(command) for command in commands if isinstance(command, dict))
        self._withdraw_dropped({str(c.get("uid")) for c in commands if isinstance(c, dict)})
        self.commands_etag = response.etag
        if taken:
            log.info("%d command(s) from the shore queued", taken)
        return taken > 0

    def _withdraw_dropped(self, listed: set[str]) -> None:
        """Withdraw the shore's commands still queued here that the shore no longer lists.

        The shore lists a command until the glider acks it, and the glider acks once the
        command is handed to the C&C; so one still queued here that left the list was
        cancelled, superseded or expired on the shore, and must not reach the C&C.
        """
        waiting = selectors.bridge_commands_queued_by(vessel=self.vessel, created_by=CREATED_BY)
        for command in waiting:
            if str(command.uid) in listed:
                continue
            if command_withdraw_queued(
                command=command, actor=CREATED_BY, detail="dropped by the shore before it left"
            ):
                log.info("shore command %s withdrawn: the shore no longer lists it", command.uid)

    def _take(self, wire: dict[str, Any]) -> bool:
        """Queue one shore command here under its own uid; True if it was new here."""
        try:
            uid = uuid.UUID(str(wire.get("uid")))
        except ValueError:
            log.warning("shore command without a valid uid: %r", wire)
            return False
        key = str(uid)
        owner = selectors.bridge_command_vessel(uid=uid)
        if owner is not None and owner != self.vessel.pk:
            log.error("shore command %s has the uid of another vessel's command here", key)
            return False
        if owner is None:
            try:
                # Its audit entry here names the shore (a system), not an operator.
                with audit_origin(SHORE_ORIGIN):
                    command_enqueue(
                        vessel=self.vessel,
                        kind=str(wire.get("kind")),
                        params=wire.get("params") or {},
                        source=Source.API,
                        created_by=CREATED_BY,
                        expires_at=when(wire.get("expires_at")),
                        uid=uid,
                    )
            except (IntegrityError, ValidationError):
                if selectors.bridge_command_vessel(uid=uid) != self.vessel.pk:
                    raise
                # Queued meanwhile from an SMS carrying the shore's reference.
                log.info("shore command %s came by SMS while it was being polled", key)
                if not self._held_as_polled(uid, wire):
                    return False
            except (CatalogError, CommandError) as exc:
                # Refused here (the glider's catalog, an inactive vessel): the shore hears why.
                log.warning("shore command %s refused here: %s", key, exc)
                if self.outbox.command_claim(key, str(wire.get("kind"))[:20]):
                    self.outbox.add_ack(key, Status.FAILED, f"refused by the glider: {exc}")
                    self.outbox.command_finish(key)
                return False
        elif not self._held_as_polled(uid, wire):
            return False
        # Claimed after the local commit: a crash in between finds the command here on the
        # next poll (the shore offers it until acked) and claims it then.
        return self.outbox.command_claim(key, str(wire.get("kind"))[:20])

    def _held_as_polled(self, uid: uuid.UUID, wire: dict[str, Any]) -> bool:
        """Whether the command held here under a polled shore command's uid says the same
        (kind, params). When not (an SMS under that uid said another), it is not taken as the
        shore's: the shore hears once that it failed here, and the one held here is no longer
        acked up under that uid (it is still reported nowhere: it is the shore's by its uid)."""
        said = selectors.bridge_command_said(uid=uid)
        kind, params = str(wire.get("kind")), wire.get("params") or {}
        if said is None or (isinstance(params, dict) and same_command(kind, params, *said)):
            return True
        key = str(uid)
        if key not in self._mismatched:
            self._mismatched.add(key)
            log.error(
                "shore command %s (%s %s) is held here as another (%s %s): acked failed",
                key, kind, params, said[0], said[1],
            )  # fmt: skip
            self.outbox.command_claim(key, kind[:20])  # already claimed if it came by SMS
            detail = f"the glider holds a different command under this uid: {said[0]} {said[1]}"
            self.outbox.add_ack(key, Status.FAILED, detail)
            self.outbox.command_finish(key)
            self._handed_over_acked.discard(key)
        return False

    def do_one_report_results(self) -> bool:
        """Queue an ack for each shore command whose progress here is news (no network)."""
        self._claim_texted()
        running = dict(self.outbox.commands_interrupted())
        if not running:
            return False
        found = selectors.bridge_commands_by_uid(running)
        queued = 0
        for key in running:
            command = found.get(key)
            if command is None:
                self.outbox.add_ack(key, Status.FAILED, "lost on the glider")
            elif command.status in FINAL:
                status = command.status if command.status in ACKED_AS_IS else Status.FAILED
                detail = command.result_detail
                if command.status not in (Status.DONE, Status.FAILED):
                    detail = f"{command.status} on the glider" + (f": {detail}" if detail else "")
                self.outbox.add_ack(key, status, detail)
            elif command.status in HANDED_OVER and key not in self._handed_over_acked:
                self.outbox.add_ack(key, Status.ACKNOWLEDGED, "handed over to the C&C")
                self._handed_over_acked.add(key)
                queued += 1
                continue
            else:
                continue
            self.outbox.command_finish(key)
            self._handed_over_acked.discard(key)
            queued += 1
        return queued > 0

    def _claim_texted(self) -> None:
        """Track the shore's commands that came by SMS (``sms.services.incoming`` queued them
        under the shore's uid) like polled ones, so that their acks go up by uid. One polled
        first is claimed already: claiming again does nothing."""
        after = self.outbox.counter(SMS_COMMAND_WATERMARK)
        texted = selectors.bridge_shore_commands_by_sms_after(
            vessel=self.vessel, created_by=CREATED_BY, after=after
        )
        for _pk, uid, kind in texted:
            if self.outbox.command_claim(str(uid), kind):
                log.info("shore command %s came by SMS; its acks go up by uid", uid)
        if texted:
            self._set_counter(SMS_COMMAND_WATERMARK, texted[-1][0])

    def do_one_flush_acks(self) -> bool:
        """Send the queued acks, oldest first; True if any left the outbox."""
        items = self.outbox.peek("ack", 50)
        for item in items:
            post_ack(self.transport, self.outbox, item)  # the edge client's own ack rule
            self._link_ok()
            self._count("acks_sent")
        return bool(items)

    # -- commands created here, up ---------------------------------------------------------------

    def do_one_report_commands(self) -> bool:
        """Report the glider's own commands with events past the watermark, as they stand now;
        True if a batch was settled (entries the shore rejects are logged and skipped; a
        refused request is kept whole and the link backs off)."""
        after = self.outbox.counter(REPORT_WATERMARK)
        last, commands = selectors.bridge_reported_commands_after(
            vessel=self.vessel,
            after=after,
            not_by=CREATED_BY,
            limit=min(self.config.batch_size, REPORT_MAX_BATCH),
        )
        if last is None:
            return False
        try:
            response = self.transport.post_json(
                REPORT_PATH, {"commands": [command_report_wire(c) for c in commands]}
            )
        except TransportError as exc:
            # Nothing is skipped on a refusal: a 404/405 is a proxy or a shore being upgraded,
            # and the shore names bad entries one by one inside a 200 ("rejected"), so a
            # whole-request 400 is a bug here. The link backs off, the watermark stays.
            if exc.status == 400:
                log.error("the shore cannot read our command report (%s); it is kept", exc)
            raise
        self._link_ok()
        answer = response.json()
        if not isinstance(answer, dict) or not isinstance(answer.get("rejected"), list):
            raise TransportError("the shore's command report answer is not the expected object")
        for rejected in answer["rejected"]:
            index = rejected.get("index") if isinstance(rejected, dict) else None
            uid = (
                commands[index].uid
                if isinstance(index, int) and 0 <= index < len(commands)
                else "?"
            )
            log.warning("shore rejected the report of command %s: %s", uid, rejected)
        self._count("commands_reported", len(commands) - len(answer["rejected"]))
        self._set_counter(REPORT_WATERMARK, last)
        return True

    # -- authorised numbers down ----------------------------------------------------------------

    def do_one_sync_numbers(self) -> bool:
        """Fetch the vessel's authorised numbers (ETag) and make them the local list."""
        response = self.transport.get(NUMBERS_PATH, self.numbers_etag)
        self._link_ok()
        self.state.numbers_synced_at = timezone.now()
        if response.status == 304:
            return False
        data = response.json()
        numbers = data.get("numbers") if isinstance(data, dict) else None
        if not isinstance(numbers, list) or not all(isinstance(n, dict) for n in numbers):
            raise TransportError("the shore's numbers answer has no list of numbers")
        result = authorised_numbers_replace(vessel=self.vessel, numbers=numbers)
        self.numbers_etag = response.etag
        log.info(
            "authorised numbers from the shore: %d added, %d updated, %d removed, %d skipped",
            result.added,
            result.updated,
            result.removed,
            len(result.rejected),
        )
        return False  # nothing more to fetch until the next period

    # -- the SMS log up -------------------------------------------------------------------------

    def do_one_upload_sms(self) -> bool:
        """Upload the next batch of the local SMS log; True if a batch went up."""
        for _batch in range(REPORT_BEFORE_SMS_MAX):
            if not self.do_one_report_commands():
                break  # the shore knows every command an SMS below may name
        else:
            return True  # a long backlog of commands: the SMS log goes up once it is through
        after = self.outbox.counter(SMS_WATERMARK)
        rows = selectors.bridge_sms_after(
            vessel=self.vessel, after=after, limit=self.config.batch_size
        )
        held_back = timezone.now() - dt.timedelta(seconds=self.config.sms_pending_grace_s)
        batch: list[SmsMessage] = []
        for message in rows:
            waiting = message.direction == Direction.OUT and message.status in UNSETTLED
            if waiting and message.created_at > held_back:
                break  # its send status is still to come; what follows waits behind it
            batch.append(message)
        if not batch:
            return False
        response = self.transport.post_json(SMS_PATH, {"messages": [sms_wire(m) for m in batch]})
        self._link_ok()
        answer = response.json()
        if not isinstance(answer, dict) or not isinstance(answer.get("rejected"), list):
            raise TransportError("the shore's SMS upload answer is not the expected object")
        for rejected in answer["rejected"]:
            log.warning("shore rejected SMS log entry %s; skipping it", rejected)
        self._count("sms_uploaded", len(batch))
        self._set_counter(SMS_WATERMARK, batch[-1].pk)
        return True
