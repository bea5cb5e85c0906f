"""The evaluator against the database, on a frozen clock: each rule kind opens once, stays
open while its condition holds and resolves itself when it clears."""

from __future__ import annotations

import datetime as dt
import math
from typing import Any

import pytest
from django.utils import timezone

from alerts.evaluator import Evaluator
from alerts.models import Alert, AlertRule, Notification
from alerts.selectors import vessel_endurance_hours
from audit.models import AuditEntry
from commands.services import command_ack, command_claim_open, command_enqueue, command_expire_due
from telemetry.models import SensorChannel
from telemetry.services import fix_ingest, track_overview_rebuild
from tests.alerts.conftest import T0, report
from tests.conftest import give_position
from vessels.models import Fence, Vessel
from vessels.services import vessel_create

pytestmark = pytest.mark.django_db


def states(rule: AlertRule) -> list[tuple[str, str]]:
    return list(Alert.objects.filter(rule=rule).order_by("pk").values_list("vessel__slug", "state"))


def events(rule: AlertRule) -> list[str]:
    return list(
        Notification.objects.filter(alert__rule=rule).order_by("pk").values_list("event", flat=True)
    )


def test_overdue_fits_each_vessels_own_period(clock: Any, evaluator: Evaluator, make_rule) -> None:
    boat = vessel_create(slug="boat", name="Boat", kind="mavlink", telemetry_period_s=10)
    glider = vessel_create(slug="glider", name="Glider", kind="wave_glider", telemetry_period_s=600)
    rule = make_rule(kind="overdue", threshold=3)
    report(boat), report(glider)
    clock.shift(30)
    evaluator.run_pass()
    assert states(rule) == []  # 30 s is not longer than 3 × 10 s
    clock.shift(1)
    evaluator.run_pass()
    assert states(rule) == [("boat", "open")]
    clock.shift(1800 - 31)
    report(boat)
    evaluator.run_pass()
    assert states(rule) == [("boat", "resolved")]  # it reported again
    clock.shift(1)
    evaluator.run_pass()
    evaluator.run_pass()
    assert states(rule) == [("boat", "resolved"), ("glider", "open")]
    assert events(rule) == ["alert.opened", "alert.resolved", "alert.opened"]
    alert = Alert.objects.get(rule=rule, vessel=glider)
    assert alert.value == 1801 and "limit 1800 s" in alert.detail


def test_a_vessel_never_seen_is_not_overdue(evaluator: Evaluator, make_rule, vessel_a) -> None:
    rule = make_rule(kind="overdue")
    evaluator.run_pass()
    assert states(rule) == []


def test_battery_hysteresis_one_episode_while_it_hovers(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel
) -> None:
    rule = make_rule(kind="battery", threshold=11.5)
    for volts in (12.0, 11.4, 11.6, 11.45, 11.65):
        clock.shift(10)
        report(vessel_a, battery_v=volts)
        evaluator.run_pass()
    assert states(rule) == [("spab", "open")]
    alert = Alert.objects.get(rule=rule)
    assert alert.value == 11.4 and alert.fix is not None and alert.fix.battery_v == 11.4
    clock.shift(10)
    report(vessel_a, battery_v=11.8)
    evaluator.run_pass()
    assert states(rule) == [("spab", "resolved")]
    assert events(rule) == ["alert.opened", "alert.resolved"]


def test_every_fix_since_the_last_pass_is_judged_in_time_order(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel
) -> None:
    """A dip and a recovery inside one pass's fixes (a store-and-forward batch) open and
    resolve an episode: the operator hears it happened."""
    rule = make_rule(kind="battery", threshold=11.5)
    now = timezone.now()
    records = [
        {"time": (now - dt.timedelta(seconds=s)).isoformat(), "lat": 0, "lon": 0, "battery_v": v}
        for s, v in ((30, 12.0), (20, 11.2), (10, 12.1))
    ]
    fix_ingest(vessel=vessel_a, records=list(reversed(records)))
    evaluator.run_pass()
    assert states(rule) == [("spab", "resolved")]
    evaluator.run_pass()  # the same fixes are in the overlap window: not judged twice
    assert Alert.objects.count() == 1


def test_reading_limits_default_to_the_sensor_channels(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel, glider: Vessel
) -> None:
    SensorChannel.objects.create(key="humidity_pct", label="Hull humidity", minimum=0, maximum=70)
    rule = make_rule(kind="reading", reading="humidity_pct", vessel_kind="mavlink")
    report(vessel_a, readings={"humidity_pct": 71.0})
    report(glider, readings={"humidity_pct": 90.0})  # not a mavlink vessel: not this rule's
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]
    clock.shift(10)
    report(vessel_a, readings={"humidity_pct": 69.0})  # inside, but not by the 2 % margin
    evaluator.run_pass()
    clock.shift(10)
    report(vessel_a, readings={"water_temp_c": 20})  # no humidity: no verdict
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]
    clock.shift(10)
    report(vessel_a, readings={"humidity_pct": 50.0})
    evaluator.run_pass()
    assert states(rule) == [("spab", "resolved")]


def test_a_rules_own_limit_beats_the_channels(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel
) -> None:
    SensorChannel.objects.create(key="humidity_pct", label="Hull humidity", minimum=0, maximum=100)
    rule = make_rule(kind="reading", reading="humidity_pct", maximum=60, vessel=vessel_a)
    report(vessel_a, readings={"humidity_pct": 65.0})
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]


def drain(vessel: Vessel, hours: int, start_v: float, per_hour: float) -> None:
    """``hours`` of fixes every 10 minutes up to now, the battery falling ``per_hour``, with a
    daytime charge on top; then the track overview is built from them, as its loop would."""
    now = timezone.now()
    records = []
    for k in range(hours * 6):
        t = now - dt.timedelta(minutes=10 * (hours * 6 - k))
        sun = 0.6 if 6 <= t.hour < 18 else 0.0
        v = start_v - per_hour * k / 6 + sun
        records.append({"time": t.isoformat(), "lat": 0.0, "lon": 0.0, "battery_v": round(v, 3)})
    assert fix_ingest(vessel=vessel, records=records).accepted == len(records)
    track_overview_rebuild(vessel=vessel)


def test_endurance_opens_below_its_hours(clock: Any, make_rule, vessel_a: Vessel, glider) -> None:
    rule = make_rule(kind="endurance", threshold=36, minimum=11.0)  # empty at 11.0 V
    drain(vessel_a, 50, start_v=12.5, per_hour=0.02)
    drain(glider, 50, start_v=12.5, per_hour=0.0)  # holding day over day: no end
    Evaluator().run_pass()
    alert = Alert.objects.get(rule=rule)
    assert (alert.vessel, alert.state) == (vessel_a, "open")
    # The last day's trough, the last night hour: 12.5 - 0.02 * 45.5 h ≈ 11.59 V, 0.59 V above
    # empty at 0.02 V/h: 29.5 h, though the day's charge put its mornings 0.6 V higher.
    assert alert.value == pytest.approx(29.6, abs=0.2)


def test_endurance_uses_the_setting_when_the_rule_has_no_empty_voltage(
    clock: Any, make_rule, vessel_a: Vessel, settings: Any
) -> None:
    settings.ALERTS_BATTERY_EMPTY_V = 9.0
    rule = make_rule(kind="endurance", threshold=24)
    drain(vessel_a, 50, start_v=12.5, per_hour=0.02)
    Evaluator().run_pass()
    assert states(rule) == []  # 2.5 V to go at 0.02 V/h: over 100 h


def test_a_failed_and_an_expired_command_each_open_their_own_alert(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel
) -> None:
    rule = make_rule(kind="command")
    give_position(vessel_a)
    hold = command_enqueue(vessel=vessel_a, kind="hold", params={})
    late = command_enqueue(
        vessel=vessel_a, kind="arm", params={}, expires_at=timezone.now() + dt.timedelta(seconds=5)
    )
    command_claim_open(vessel=vessel_a, kinds=["hold"])
    command_ack(vessel=vessel_a, uid=hold.uid, status="failed", detail="no GPS")
    clock.shift(6)
    command_expire_due()
    evaluator.run_pass()
    evaluator.run_pass()
    alerts = {a.subject: a for a in Alert.objects.filter(rule=rule)}
    assert set(alerts) == {str(hold.uid), str(late.uid)}
    assert alerts[str(hold.uid)].detail == "hold failed: no GPS"
    assert alerts[str(late.uid)].detail.startswith("arm expired")
    # A later hold that ends done resolves the failed hold's alert, not the expired arm's.
    clock.shift(5)
    again = command_enqueue(vessel=vessel_a, kind="hold", params={})
    command_claim_open(vessel=vessel_a, kinds=["hold"])
    command_ack(vessel=vessel_a, uid=again.uid, status="done")
    evaluator.run_pass()
    assert Alert.objects.get(subject=str(hold.uid)).state == "resolved"
    assert Alert.objects.get(subject=str(late.uid)).state == "open"
    # A new evaluator (a restart) reads the last hour's ends again but opens nothing twice.
    Evaluator(since=timezone.now()).run_pass()
    assert Alert.objects.filter(rule=rule).count() == 2


HARBOUR = {
    "type": "Polygon",
    "coordinates": [[[115.69, -32.03], [115.71, -32.03], [115.71, -32.01], [115.69, -32.01],
                     [115.69, -32.03]]],
}  # fmt: skip


def test_fence_inclusion_out_and_back_in(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel
) -> None:
    fence = Fence.objects.create(name="Harbour", geometry=HARBOUR, inclusion=True)
    rule = make_rule(kind="fence", fence=fence)
    report(vessel_a, lat=-32.02, lon=115.70)
    evaluator.run_pass()
    assert states(rule) == []
    clock.shift(10)
    report(vessel_a, lat=-32.02, lon=115.72)  # east of the harbour
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]
    assert "outside inclusion fence Harbour" in Alert.objects.get(rule=rule).detail
    clock.shift(10)
    report(vessel_a, lat=-32.02, lon=115.7099)  # back in, but 9 m from the line
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]
    clock.shift(10)
    report(vessel_a, lat=-32.02, lon=115.70)
    evaluator.run_pass()
    assert states(rule) == [("spab", "resolved")]


def test_fence_exclusion_and_circle(clock: Any, evaluator: Evaluator, make_rule, vessel_a) -> None:
    reef = Fence.objects.create(
        name="Reef",
        geometry={"type": "Point", "coordinates": [115.70, -32.02]},
        radius_m=500,
        inclusion=False,
    )
    rule = make_rule(kind="fence", fence=reef)
    report(vessel_a, lat=-32.0205, lon=115.7005)  # ~70 m from the centre: inside the reef
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]
    assert "inside exclusion fence Reef" in Alert.objects.get(rule=rule).detail


def test_a_fence_of_one_vessel_does_not_watch_the_others(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel, vessel_b: Vessel
) -> None:
    fence = Fence.objects.create(name="Harbour", geometry=HARBOUR, vessel=vessel_b)
    rule = make_rule(kind="fence", fence=fence)
    report(vessel_a, lat=-31.0, lon=115.0)
    report(vessel_b, lat=-31.0, lon=115.0)
    evaluator.run_pass()
    assert states(rule) == [("spab-2", "open")]


def test_a_failing_rule_is_pushed_aside_and_the_others_carry_on(
    clock: Any, make_rule, vessel_a: Vessel, monkeypatch: pytest.MonkeyPatch
) -> None:
    broken = make_rule(kind="battery", threshold=11.5, name="broken")
    working = make_rule(kind="battery", threshold=11.5, name="working")
    moment = [0.0]
    evaluator = Evaluator(clock=lambda: moment[0])
    real = Evaluator.judge_battery

    def judge(self: Evaluator, rule: AlertRule, snap: Any, ep: Any) -> None:
        if rule.pk == broken.pk:
            raise RuntimeError("a bug in one rule")
        real(self, rule, snap, ep)

    monkeypatch.setattr(Evaluator, "judge_battery", judge)
    report(vessel_a, battery_v=11.0)
    result = evaluator.run_pass()
    assert result.failed_rules == [broken.pk]
    assert states(working) == [("spab", "open")]
    assert evaluator.run_pass().rules == 1  # the broken one is left out for a while
    moment[0] = 61.0
    assert evaluator.run_pass().failed_rules == [broken.pk]


def test_an_inactive_rule_or_vessel_is_not_judged(
    clock: Any, evaluator, make_rule, vessel_a
) -> None:
    make_rule(kind="battery", threshold=11.5, active=False)
    report(vessel_a, battery_v=11.0)
    evaluator.run_pass()
    assert not Alert.objects.exists()
    rule = make_rule(kind="overdue")
    Vessel.objects.filter(pk=vessel_a.pk).update(active=False)
    clock.shift(3600)
    evaluator.run_pass()
    assert states(rule) == []


def test_acknowledging_records_who_and_when_and_audits(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel, operator_user
) -> None:
    from alerts.services.alerts import alert_acknowledge

    rule = make_rule(kind="battery", threshold=11.5)
    report(vessel_a, battery_v=11.0)
    evaluator.run_pass()
    alert = Alert.objects.get(rule=rule)
    assert alert_acknowledge(alert=alert, by=operator_user, via="api", ip="10.0.0.1")
    assert not alert_acknowledge(alert=alert, by=operator_user)  # once
    alert.refresh_from_db()
    assert (alert.state, alert.acknowledged_by, alert.acknowledged_at) == (
        "acknowledged", operator_user.username, T0,
    )  # fmt: skip
    entry = AuditEntry.objects.get(action="alert.acknowledged")
    assert (entry.actor, entry.vessel, entry.subject_id, entry.ip) == (
        operator_user.username, "spab", str(alert.pk), "10.0.0.1",
    )  # fmt: skip
    # Acknowledged is still active: the condition clearing resolves it.
    clock.shift(10)
    report(vessel_a, battery_v=12.5)
    evaluator.run_pass()
    assert states(rule) == [("spab", "resolved")]
    assert events(rule) == ["alert.opened", "alert.acknowledged", "alert.resolved"]


def test_the_vessel_panels_endurance_is_the_rules(clock: Any, vessel_a: Vessel, glider) -> None:
    drain(vessel_a, 50, start_v=12.5, per_hour=0.02)
    drain(glider, 50, start_v=12.5, per_hour=0.0)
    assert vessel_endurance_hours(vessel=vessel_a, empty_v=11.0) == pytest.approx(29.6, abs=0.2)
    assert vessel_endurance_hours(vessel=glider) == math.inf
    assert vessel_endurance_hours(vessel=vessel_create(slug="new", name="New")) is None


def test_an_hour_later_the_means_are_brought_up_to_date_not_read_whole(
    clock: Any, vessel_a: Vessel
) -> None:
    drain(vessel_a, 50, start_v=12.5, per_hour=0.02)
    evaluator = Evaluator()
    before = evaluator.endurance([vessel_a.pk], 11.0, timezone.now())[vessel_a.pk]
    clock.shift(3600)
    # A sharp fall in the hour that just ended.
    report(vessel_a, when=timezone.now() - dt.timedelta(minutes=30), battery_v=10.0)
    track_overview_rebuild(vessel=vessel_a)
    after = evaluator.endurance([vessel_a.pk], 11.0, timezone.now())[vessel_a.pk]
    fresh = Evaluator().endurance([vessel_a.pk], 11.0, timezone.now())[vessel_a.pk]
    assert after == fresh != before
    whole = Evaluator().hourly_means([vessel_a.pk], timezone.now())[vessel_a.pk]
    assert evaluator.hourly[vessel_a.pk][1] == whole


def test_a_fix_committed_after_a_pass_that_looked_past_its_stamp_is_still_judged(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel, settings: Any
) -> None:
    """Ingest stamps received_at before its transaction commits: a fix stamped 5 s before a
    pass may only become visible after it. The next pass reads back ALERTS_FIX_OVERLAP_S."""
    rule = make_rule(kind="battery", threshold=11.5)
    clock.shift(10)
    evaluator.run_pass()
    stamped = timezone.now() - dt.timedelta(seconds=5)
    fix_ingest(vessel=vessel_a, records=[{"time": stamped.isoformat(), "lat": 0, "lon": 0,
                                          "battery_v": 11.0}], now=stamped)  # fmt: skip
    clock.shift(10)
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]
    # Older than the overlap: a pass does not read that far back.
    stale = timezone.now() - dt.timedelta(seconds=settings.ALERTS_FIX_OVERLAP_S + 20)
    late = vessel_create(slug="late", name="Late")
    record = {"time": stale.isoformat(), "lat": 0, "lon": 0, "battery_v": 11.0}
    fix_ingest(vessel=late, records=[record], now=stale)
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]


def test_a_pass_that_fails_before_judging_leaves_its_fixes_to_the_next(
    clock: Any, evaluator: Evaluator, make_rule, vessel_a: Vessel, monkeypatch: pytest.MonkeyPatch
) -> None:
    rule = make_rule(kind="battery", threshold=11.5)
    report(vessel_a, battery_v=11.0)
    with monkeypatch.context() as m:
        m.setattr(SensorChannel.objects, "values", lambda *a: 1 / 0)  # the database fails
        make_rule(kind="reading", reading="humidity_pct", maximum=70)
        with pytest.raises(ZeroDivisionError):
            evaluator.run_pass()
    clock.shift(10)
    evaluator.run_pass()
    assert states(rule) == [("spab", "open")]


def test_the_vessel_page_shows_the_endurance(clock: Any, vessel_a: Vessel, admin_ui) -> None:
    page = admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()
    assert "not enough history yet" in page
    drain(vessel_a, 50, start_v=12.5, per_hour=0.02)
    page = admin_ui.get(f"/admin/vessels/vessel/{vessel_a.pk}/change/").content.decode()
    hours = vessel_endurance_hours(vessel=vessel_a)
    assert f"{hours:.0f} h to empty (10.5 V), day over day" in page
