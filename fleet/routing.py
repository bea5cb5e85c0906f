"""Per-vessel routing: queued commands relayed by SMS or Iridium SBD when HTTP cannot be
trusted to carry them (the rule is links.routing's, pure; this is its one pass over the
database, run by ``manage.py run_links``).

Here, on the top floor, because it joins four apps: commands (what waits), links (what each
vessel's links did today), sms and sbd (the two ways out), and alerts' SMS sender (the shore's
own modem or its HTTP gateway, the one alerts text through).

Each relay is claimed on the command first (``command_relay_claim``), so two passes side by
side never send one command twice; a link that cannot carry it (no SMS form for a long mission,
270 bytes for SBD, a send that failed for good) hands the claim to the next, and a command no
link can carry is marked ``none`` with the reasons in its history, so it is not tried again.
"""

from __future__ import annotations

import datetime as dt
import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from enum import Enum

from django.conf import settings
from django.db.models import Count, Max, Q
from django.utils import timezone

from commands.lifecycle import Status
from commands.models import Command, Relay
from commands.services import command_note, command_relay_claim
from links.models import LinkDay, Transport
from links.routing import PREFERENCE, Decision, Route, VesselLinks, decide
from vessels.models import OVERDUE_PERIODS, Vessel, VesselKind

logger = logging.getLogger(__name__)
BATCH = 500
# A command whose links fail for now is tried this many passes, then marked none.
RELAY_TRIES = 3
RETRY_MARK = "trying again next pass"
# What a route's budget is counted in, per vessel: today's LinkDay credits (SMS segments, SBD
# credits); the budgets are the vessel's own fields (the budget alert reads the same).
BUDGET_FIELD = {Route.SMS: "sms_daily_budget", Route.SBD: "sbd_daily_credit_budget"}


class Refused(Exception):
    """This link did not carry this command; the message says why (for its history).
    ``temporary``: it may next time (a gateway down, the modem busy with an alert's text)."""

    def __init__(self, message: str, *, temporary: bool = False) -> None:
        super().__init__(message)
        self.temporary = temporary


@dataclass(frozen=True)
class Sent:
    """What a link did with a command: a line for its history, and what it cost in the
    link's budget units (SMS segments, SBD credits)."""

    note: str
    cost: int = 1


# A link's way out: sends one command, returns Sent, raises Refused when it did not carry it.
Sender = Callable[[Command, dt.datetime], Sent]


@dataclass
class RoutingReport:
    relayed: list[tuple[str, Route]] = field(default_factory=list)
    impossible: list[str] = field(default_factory=list)
    retrying: list[str] = field(default_factory=list)


class _Outcome(Enum):
    GONE = "gone"  # another pass has it, or it was cancelled, expired, polled meanwhile
    IMPOSSIBLE = "impossible"  # no link could carry it: marked none
    RETRY = "retry"  # a link failed for now: released for a later pass


def _reachable(
    vessel: Vessel, senders: Mapping[Route, Sender], sms_recent: int = 0
) -> frozenset[Route]:
    routes = set()
    # Only a glider's bridge reads commands in SMS; an ArduPilot boat's modem is for data.
    # Not past the glider's rate limit either (the same setting: a text past it is logged
    # there and not run), counted over the shore's texts to it in the window.
    if (
        Route.SMS in senders
        and vessel.sms_number
        and vessel.kind == VesselKind.WAVE_GLIDER
        and sms_recent < settings.SMS_RATE_LIMIT
    ):
        routes.add(Route.SMS)
    if Route.SBD in senders and vessel.imei:
        routes.add(Route.SBD)
    return frozenset(routes)


def _pending(now: dt.datetime, limit: int, senders: Mapping[Route, Sender]) -> list[Command]:
    """Queued commands of vessels one of ``senders`` can reach, urgent ones first: a vessel
    no configured link reaches never fills the batch."""
    reachable = Q(pk__in=[])
    if Route.SBD in senders:
        reachable |= Q(vessel__imei__isnull=False)
    if Route.SMS in senders:
        reachable |= Q(vessel__kind=VesselKind.WAVE_GLIDER) & ~Q(vessel__sms_number="")
    unexpired = Q(expires_at__isnull=True) | Q(expires_at__gt=now)
    return list(
        Command.objects.filter(reachable, unexpired, status=Status.QUEUED, relay="", reported=False)
        .filter(vessel__active=True)
        .select_related("vessel")
        .order_by("-urgent", "created_at", "pk")[:limit]
    )


def _links_today(vessel_ids: Iterable[int], now: dt.datetime) -> dict[int, dict]:
    """Per vessel: its newest HTTP contact (any day), today's SMS and SBD spending, and the
    commands texted to it within the SMS rate window."""
    ids = list(vessel_ids)
    out: dict[int, dict] = {pk: {"last_http_at": None, "spent": {}, "sms_recent": 0} for pk in ids}
    heard = (
        LinkDay.objects.filter(vessel_id__in=ids, transport=Transport.HTTP)
        .values("vessel_id")
        .annotate(at=Max("last_contact_at"))
    )
    for row in heard:
        out[row["vessel_id"]]["last_http_at"] = row["at"]
    today = LinkDay.objects.filter(
        vessel_id__in=ids, day=now.astimezone(dt.UTC).date(), transport__in=list(PREFERENCE)
    ).values_list("vessel_id", "transport", "credits")
    for vessel_id, transport, spent in today:
        out[vessel_id]["spent"][Route(transport)] = spent
    window = now - dt.timedelta(seconds=settings.SMS_RATE_WINDOW_S)
    texted = (
        Command.objects.filter(vessel_id__in=ids, relay=Relay.SMS, relayed_at__gt=window)
        .values("vessel_id")
        .annotate(n=Count("pk"))
    )
    for row in texted:
        out[row["vessel_id"]]["sms_recent"] = row["n"]
    return out


def vessel_links(vessel: Vessel, known: Mapping, usable: frozenset[Route]) -> VesselLinks:
    return VesselLinks(
        period_s=vessel.telemetry_period_s,
        overdue_periods=OVERDUE_PERIODS,
        last_http_at=known["last_http_at"],
        usable=usable,
        spent=known["spent"],
        budget={route: getattr(vessel, name) for route, name in BUDGET_FIELD.items()},
    )


def route_pending(
    *, senders: Mapping[Route, Sender], now: dt.datetime | None = None, limit: int = BATCH
) -> RoutingReport:
    """One pass: every queued command that should go by another link goes, urgent ones
    first, then oldest first."""
    now = now or timezone.now()
    report = RoutingReport()
    if not senders:
        return report
    pending = _pending(now, limit, senders)
    if not pending:
        return report
    known = _links_today({c.vessel_id for c in pending}, now)
    for command in pending:
        vessel = command.vessel
        state = known[vessel.pk]
        usable = _reachable(vessel, senders, state["sms_recent"])
        decision = decide(vessel_links(vessel, state, usable), urgent=command.urgent, now=now)
        if not decision.routes:
            continue
        outcome = _relay(command, decision, senders, now)
        if isinstance(outcome, tuple):
            route, cost = outcome
            report.relayed.append((str(command.uid), route))
            # Counted before the next command: a budget can run out within one pass, and
            # the glider's rate limit too.
            state["spent"][route] = state["spent"].get(route, 0) + cost
            if route is Route.SMS:
                state["sms_recent"] += 1
        elif outcome is _Outcome.IMPOSSIBLE:
            report.impossible.append(str(command.uid))
        elif outcome is _Outcome.RETRY:
            report.retrying.append(str(command.uid))
    return report


def _relay(
    command: Command, decision: Decision, senders: Mapping[Route, Sender], now: dt.datetime
) -> tuple[Route, int] | _Outcome:
    """Try the decision's links in order: (the one that took it, its cost), or what else
    became of it. A link that failed for now (``Refused.temporary``) puts the command back
    for a later pass, RELAY_TRIES times at most; then, or when no link can carry it at all,
    it is marked ``none``."""
    was, reasons, temporary = "", [], False
    for route in decision.routes:
        if not command_relay_claim(command=command, relay=route.value, was=was, now=now):
            return _Outcome.GONE
        was = route.value
        try:
            sent = senders[route](command, now)
        except Refused as exc:
            reasons.append(f"{route.value}: {exc}")
            temporary = temporary or exc.temporary
            continue
        note = f"{decision.reason}: {sent.note}"
        if reasons:  # the links before it that did not carry it, and why
            note += f" (not by {'; '.join(reasons)})"
        command_note(command=command, actor="shore", now=now, detail=note)
        logger.info("command %s relayed by %s (%s)", command.uid, route.value, decision.reason)
        return route, sent.cost
    tries = _failed_tries(command) + 1
    if temporary and tries < RELAY_TRIES:
        if command_relay_claim(command=command, relay="", was=was, now=now):
            detail = (
                f"{decision.reason}, but not sent ({'; '.join(reasons)}): "
                f"trying again next pass (try {tries} of {RELAY_TRIES})"
            )
            command_note(command=command, actor="shore", now=now, detail=detail)
            logger.warning("command %s: %s", command.uid, detail)
        return _Outcome.RETRY
    if command_relay_claim(command=command, relay=Relay.NONE, was=was, now=now):
        detail = f"{decision.reason}, but no link could carry it: " + "; ".join(reasons)
        command_note(command=command, actor="shore", now=now, detail=detail)
        logger.warning("command %s: %s", command.uid, detail)
    return _Outcome.IMPOSSIBLE


def _failed_tries(command: Command) -> int:
    """Passes that released ``command`` after a failure for now (their notes say so)."""
    return command.events.filter(actor="shore", detail__contains=RETRY_MARK).count()


ROUTE_NAMES = {Route.SMS: "SMS", Route.SBD: "Iridium SBD"}


def routing_summary(
    vessel: Vessel, senders: Mapping[Route, Sender], now: dt.datetime | None = None
) -> str:
    """One sentence for the vessel's page: which links its commands take now, and why."""
    now = now or timezone.now()
    usable = _reachable(vessel, senders)
    if not usable:
        return "Commands go by HTTP alone: no SMS number or Iridium IMEI the site can send to."
    links = vessel_links(vessel, _links_today([vessel.pk], now)[vessel.pk], usable)
    names = " or ".join(ROUTE_NAMES[r] for r in PREFERENCE if r in usable)
    calm = decide(links, urgent=False, now=now)
    if calm.routes:
        ways = ", then ".join(ROUTE_NAMES[r] for r in calm.routes)
        return f"Queued commands also go by {ways}: {calm.reason}."
    if links.http_silent(now):
        return f"Queued commands wait for HTTP: {calm.reason}."
    return f"HTTP is reporting: commands go by HTTP; urgent ones also by {names}."
