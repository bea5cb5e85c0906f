"""Which link carries a command besides HTTP: the per-vessel routing rule, pure.

HTTP is always first: a queued command waits for the boat's poll (or its telemetry answer)
whatever else happens, and the boat runs a command once whichever way it came (by its uid).
The other links are paid per message, so they carry a command only when

- the command is urgent (the operator asked for it to go every way at once), or
- the vessel's HTTP link has been silent past its schedule: nothing heard over HTTP for
  ``OVERDUE_PERIODS`` telemetry periods (or never), the same test as the vessel's *overdue*.

Then the first link the vessel has, cheapest first (SMS, then Iridium SBD), whose daily budget
is not yet spent; an urgent command goes even over budget (the budget alert still says so).
One relay per command: what a link took is not sent again by another.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum


class Route(StrEnum):
    SMS = "sms"
    SBD = "sbd"


# Cheapest first: an SMS is a few cents, an SBD credit about the same for 50 bytes, and a
# glider's SMS is its own language (a reply comes back).
PREFERENCE = (Route.SMS, Route.SBD)


@dataclass(frozen=True)
class VesselLinks:
    """What the shore knows of one vessel's links at the time of a pass."""

    period_s: int
    overdue_periods: int
    last_http_at: dt.datetime | None
    # The links it can be reached on (it has the number or modem, and the shore a sender).
    usable: frozenset[Route] = frozenset()
    # Today's spending on each link (SMS segments, SBD credits) and its budget (None: none).
    spent: Mapping[Route, int] = field(default_factory=dict)
    budget: Mapping[Route, int | None] = field(default_factory=dict)

    def http_silent(self, now: dt.datetime) -> bool:
        if self.last_http_at is None:
            return True
        return now - self.last_http_at > dt.timedelta(seconds=self.period_s * self.overdue_periods)

    def over_budget(self, route: Route) -> bool:
        budget = self.budget.get(route)
        return budget is not None and self.spent.get(route, 0) >= budget


@dataclass(frozen=True)
class Decision:
    routes: tuple[Route, ...]  # to try in order; empty: HTTP alone
    reason: str


def decide(links: VesselLinks, *, urgent: bool, now: dt.datetime) -> Decision:
    """The links to try for one queued command, in order, and why."""
    if not links.usable:
        return Decision((), "no SMS number or Iridium modem the shore can reach")
    silent = links.http_silent(now)
    if not urgent and not silent:
        return Decision((), "HTTP is reporting")
    why = "urgent" if urgent else _silence(links, now)
    routes = []
    skipped = []
    for route in PREFERENCE:
        if route not in links.usable:
            continue
        if links.over_budget(route) and not urgent:
            skipped.append(f"{route.value} budget spent")
            continue
        routes.append(route)
    if not routes:
        return Decision((), f"{why}, but " + " and ".join(skipped))
    return Decision(tuple(routes), why)


def _silence(links: VesselLinks, now: dt.datetime) -> str:
    if links.last_http_at is None:
        return "never heard over HTTP"
    minutes = (now - links.last_http_at).total_seconds() / 60
    return f"silent over HTTP for {minutes:.0f} min (its schedule: {links.period_s} s)"
