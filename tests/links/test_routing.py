"""The routing rule alone (links.routing): which link besides HTTP, and why."""

from __future__ import annotations

import datetime as dt

from hypothesis import given
from hypothesis import strategies as st

from links.routing import PREFERENCE, Route, VesselLinks, decide

NOW = dt.datetime(2026, 11, 28, 3, 0, tzinfo=dt.UTC)
BOTH = frozenset({Route.SMS, Route.SBD})


def links(ago_s: float | None = 30, usable: frozenset[Route] = BOTH, **kw) -> VesselLinks:
    last = None if ago_s is None else NOW - dt.timedelta(seconds=ago_s)
    return VesselLinks(period_s=60, overdue_periods=3, last_http_at=last, usable=usable, **kw)


def test_a_reporting_vessel_gets_its_commands_by_http_alone() -> None:
    decision = decide(links(ago_s=179), urgent=False, now=NOW)
    assert decision.routes == () and decision.reason == "HTTP is reporting"


def test_silent_past_its_schedule_the_cheapest_link_goes_first() -> None:
    decision = decide(links(ago_s=181), urgent=False, now=NOW)
    assert decision.routes == (Route.SMS, Route.SBD)
    assert decision.reason == "silent over HTTP for 3 min (its schedule: 60 s)"


def test_never_heard_over_http_is_silent() -> None:
    decision = decide(links(ago_s=None, usable=frozenset({Route.SBD})), urgent=False, now=NOW)
    assert decision.routes == (Route.SBD,) and decision.reason == "never heard over HTTP"


def test_an_urgent_command_goes_at_once_even_over_budget() -> None:
    spent = links(ago_s=5, spent={Route.SMS: 10, Route.SBD: 3}, budget={Route.SMS: 10})
    decision = decide(spent, urgent=True, now=NOW)
    assert decision.routes == (Route.SMS, Route.SBD) and decision.reason == "urgent"


def test_a_spent_budget_skips_that_link_when_not_urgent() -> None:
    spent = links(ago_s=600, spent={Route.SMS: 10}, budget={Route.SMS: 10, Route.SBD: 5})
    assert decide(spent, urgent=False, now=NOW).routes == (Route.SBD,)
    broke = links(
        ago_s=600, spent={Route.SMS: 10, Route.SBD: 5}, budget={Route.SMS: 10, Route.SBD: 5}
    )
    decision = decide(broke, urgent=False, now=NOW)
    assert decision.routes == ()
    assert decision.reason == (
        "silent over HTTP for 10 min (its schedule: 60 s), "
        "but sms budget spent and sbd budget spent"
    )


def test_a_vessel_with_no_other_link_has_http_alone() -> None:
    decision = decide(links(ago_s=None, usable=frozenset()), urgent=True, now=NOW)
    assert decision.routes == ()
    assert decision.reason == "no SMS number or Iridium modem the shore can reach"


@given(
    ago=st.one_of(st.none(), st.floats(0, 10 * 86400)),
    usable=st.sets(st.sampled_from(list(Route))).map(frozenset),
    urgent=st.booleans(),
    spent=st.dictionaries(st.sampled_from(list(Route)), st.integers(0, 50)),
    budget=st.dictionaries(st.sampled_from(list(Route)), st.one_of(st.none(), st.integers(0, 50))),
)
def test_routes_are_usable_in_preference_order_and_only_when_called_for(
    ago, usable, urgent, spent, budget
) -> None:
    state = links(ago_s=ago, usable=usable, spent=spent, budget=budget)
    routes = decide(state, urgent=urgent, now=NOW).routes
    assert set(routes) <= usable
    assert list(routes) == [r for r in PREFERENCE if r in routes]
    if routes and not urgent:
        assert state.http_silent(NOW)
        assert not any(state.over_budget(r) for r in routes)
    if urgent:
        assert set(routes) == usable
