"""Budget rules: the pure verdict, and the evaluator reading today's link counts on a frozen
clock (one episode per vessel and transport; resolved the next UTC day or when raised)."""

from __future__ import annotations

import datetime as dt
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from alerts import rules as R
from alerts.evaluator import Evaluator
from alerts.models import Alert, AlertRule, Notification
from alerts.services.rules import rule_problems
from links.services import link_count
from tests.alerts.conftest import T0
from vessels.models import Vessel
from vessels.services import vessel_create

# -- pure ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("spent", "limit", "verdict"),
    [(0, 10, R.CLEARS), (10, 10, R.CLEARS), (11, 10, R.HOLDS), (11, None, R.CLEARS),
     (11, float("nan"), R.CLEARS), (0.5, 0, R.HOLDS)],
)  # fmt: skip
def test_a_budget_holds_only_once_spending_is_over_it(
    spent: float, limit: float | None, verdict: R.Verdict
) -> None:
    assert R.budget(spent, limit) is verdict


@given(st.lists(st.integers(0, 20), max_size=50), st.integers(1, 200))
def test_a_day_of_growing_spending_opens_one_episode_at_most(steps: list[int], limit: int) -> None:
    spent, verdicts = 0, []
    for step in steps:
        spent += step
        verdicts.append(R.budget(spent, limit))
    active, transitions = R.run(False, verdicts)
    assert transitions in ([], ["open"])
    assert active == (spent > limit)
    # The next UTC day starts from nothing: the episode resolves.
    assert R.run(active, [R.budget(0, limit)])[1] == (["resolve"] if active else [])


# -- the evaluator ---------------------------------------------------------------------------


def states(rule: AlertRule) -> list[tuple[str, str, str]]:
    return list(
        Alert.objects.filter(rule=rule)
        .order_by("pk")
        .values_list("vessel__slug", "subject", "state")
    )


@pytest.fixture
def sat(db: None) -> Vessel:
    return with_budget(vessel_create(slug="sat", name="Sat", kind="mavlink"), 10)


def with_budget(vessel: Vessel, credits: int) -> Vessel:
    Vessel.objects.filter(pk=vessel.pk).update(sbd_daily_credit_budget=credits)
    return vessel


def spend_sbd(vessel: Vessel, credits: int, at: dt.datetime | None = None) -> None:
    from django.utils import timezone

    link_count(vessel_id=vessel.pk, transport="sbd", at=at or timezone.now(), contact=True,
               messages_in=1, bytes_in=credits * 50, credits=credits)  # fmt: skip


@pytest.mark.django_db
def test_crossing_the_budget_opens_once_and_the_next_day_resolves(
    clock: Any, evaluator: Evaluator, make_rule: Any, sat: Vessel
) -> None:
    rule = make_rule(kind="budget")
    spend_sbd(sat, 6)
    evaluator.run_pass()
    assert states(rule) == []
    spend_sbd(sat, 4)
    evaluator.run_pass()
    assert states(rule) == []  # 10 of 10: not crossed yet
    spend_sbd(sat, 1)
    evaluator.run_pass()
    assert states(rule) == [("sat", "sbd", "open")]
    alert = Alert.objects.get(rule=rule)
    assert alert.value == 11 and alert.detail == "sbd: 11 credits today, over the budget of 10"
    spend_sbd(sat, 5)
    evaluator.run_pass()
    assert states(rule) == [("sat", "sbd", "open")]  # one episode, not one per message
    clock.move_to(dt.datetime(2026, 11, 24, 0, 0, 1, tzinfo=dt.UTC))  # the next UTC day
    evaluator.run_pass()
    assert states(rule) == [("sat", "sbd", "resolved")]
    events = Notification.objects.filter(alert__rule=rule).values_list("event", flat=True)
    assert sorted(events) == ["alert.opened", "alert.resolved"]


@pytest.mark.django_db
def test_raising_the_budget_resolves_it(
    clock: Any, evaluator: Evaluator, make_rule: Any, sat: Vessel
) -> None:
    rule = make_rule(kind="budget", reading="sbd")
    spend_sbd(sat, 12)
    evaluator.run_pass()
    assert states(rule) == [("sat", "sbd", "open")]
    Vessel.objects.filter(pk=sat.pk).update(sbd_daily_credit_budget=20)
    evaluator.run_pass()
    assert states(rule) == [("sat", "sbd", "resolved")]


@pytest.mark.django_db
def test_the_rules_threshold_is_the_budget_of_a_vessel_without_one(
    clock: Any, evaluator: Evaluator, make_rule: Any, sat: Vessel
) -> None:
    glider = vessel_create(slug="glider", name="Glider", kind="wave_glider")
    make_rule(kind="budget", reading="sms", threshold=3)
    http_rule = make_rule(kind="budget", reading="http", name="http")
    for vessel, segments in ((sat, 3), (glider, 4)):
        link_count(vessel_id=vessel.pk, transport="sms", at=T0, messages_in=segments,
                   credits=segments)  # fmt: skip
    Vessel.objects.filter(pk=glider.pk).update(http_daily_budget_kb=2)
    link_count(vessel_id=glider.pk, transport="http", at=T0, bytes_in=1500, bytes_out=600)
    evaluator.run_pass()
    opened = Alert.objects.order_by("subject").values_list("vessel__slug", "subject", "detail")
    assert list(opened) == [
        ("glider", "http", "http: 2.1 kB today, over the budget of 2"),
        ("glider", "sms", "sms: 4 SMS segments today, over the budget of 3"),
    ]
    assert states(http_rule) == [("glider", "http", "open")]


@pytest.mark.django_db
def test_a_pass_reads_the_link_counts_once(
    clock: Any, evaluator: Evaluator, make_rule: Any, sat: Vessel, django_assert_num_queries: Any
) -> None:
    make_rule(kind="budget")
    make_rule(kind="budget", reading="sbd", name="again")
    for i in range(5):
        with_budget(vessel_create(slug=f"v{i}", name=f"V{i}", kind="mavlink"), 1)
    evaluator.run_pass()  # nothing over: nothing written
    from django.db import connection
    from django.test.utils import CaptureQueriesContext

    with CaptureQueriesContext(connection) as queries:
        evaluator.run_pass()
    reads = [q["sql"] for q in queries if "links_linkday" in q["sql"]]
    assert len(reads) == 1


@pytest.mark.django_db
def test_a_budget_rule_names_a_transport_or_none(channel: Any) -> None:
    assert rule_problems(AlertRule(name="b", kind="budget")) == {}
    assert rule_problems(AlertRule(name="b", kind="budget", reading="sbd", threshold=50)) == {}
    problems = rule_problems(AlertRule(name="b", kind="budget", reading="wifi", threshold=-1))
    assert set(problems) == {"reading", "threshold"}
    assert set(rule_problems(AlertRule(name="b", kind="budget", minimum=1))) == {"minimum"}
