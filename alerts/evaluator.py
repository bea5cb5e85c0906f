"""The alerts evaluator: one pass judges every active rule on every vessel it covers.

A pass reads only what changed, in a handful of bulk queries whatever the fleet's size:

1. the active rules (a rule failing this process is pushed aside for a while, see PushAside);
2. the active vessels (id, kind, telemetry period, last seen): overdue rules need nothing else;
3. the active alert episodes, keyed (rule, vessel, subject);
4. the fixes *received* since the previous pass, for battery, reading and fence rules;
5. the hourly battery means of the last two days (the track overview's buckets), only for
   vessels with an endurance rule and only when the hour has rolled over since last computed;
6. the commands that ended since the previous pass, for command rules;
7. today's link spending (links.LinkDay), for budget rules.

Then each rule runs its observations through alerts/rules.py's state machine per vessel, in
time order, opening and resolving episodes through alerts/services/alerts.py (which queue the
notifications), written after the rule is judged, in one transaction per rule. A rule whose
evaluation raises is logged and left out of the next passes for a while, doubling up to an
hour; the other rules carry on.

**Which fixes are new.** A fix is stamped ``received_at`` by ingest *before* its transaction
commits, and on PostgreSQL neither ids nor those stamps become visible in order: a pass at
12:00:10 may miss a fix stamped 12:00:09.9 that commits at 12:00:10.2. So each pass reads back
to ALERTS_FIX_OVERLAP_S before the previous pass's start and skips the ids it has already
judged (kept for the overlap window only). The same for commands and ``finished_at``, where an
episode per command uid makes a second look harmless anyway.

**Restarts.** The cursor lives in the process. A new evaluator starts at its own start time
(``since`` in tests and ``run_alerts --once``, which looks back one period): fixes received
while none ran are not replayed, but overdue, endurance and command rules judge state, not
fixes, and a threshold rule is judged again on the vessel's next fix.

**Two evaluators at once** (a deploy overlapping, two hosts) are safe, not useful: each opens
through the partial unique constraint and resolves with a conditional UPDATE, so one episode
and one set of notifications result (tests/alerts/test_race.py).
"""

from __future__ import annotations

import datetime as dt
import logging
import math
import time
from collections import defaultdict
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from django.conf import settings
from django.db import transaction
from django.utils import timezone

from alerts import rules as R
from alerts.budget import BUDGET_FIELDS, budget_limit, spent_today
from alerts.endurance import HOUR_S, endurance_hours, hourly_means_from_channels
from alerts.models import ACTIVE_STATES, Alert, AlertRule, RuleKind
from alerts.services.alerts import alert_open, alert_resolve
from commands.models import Command
from edge_client.contract.backoff import UNTIL_THE_CAP, after_failures
from edge_client.contract.fence import containment, wire_fence
from edge_client.contract.status import Status
from telemetry.models import Fix, SensorChannel, TrackBucket
from vessels.models import Vessel

logger = logging.getLogger(__name__)

# A rule whose evaluation raised is skipped for this long, doubling per failure, up to the max.
RETRY_FIRST_S = 60.0
RETRY_MAX_S = 3600.0
# A fresh evaluator looks this far back for ended commands (a restart must not lose one; an
# episode per command uid makes reading one twice harmless).
COMMAND_LOOKBACK = dt.timedelta(hours=1)
# Hourly means kept per vessel for endurance: two days and the hour in progress.
ENDURANCE_HOURS = 49
# ... of which the newest few are read again each hour (the overview may rebuild them late).
REREAD_HOURS = 3
FIX_RULES = (RuleKind.BATTERY, RuleKind.READING, RuleKind.FENCE)
FIX_FIELDS = ("id", "vessel_id", "recorded_at", "received_at", "lat", "lon", "battery_v",
              "readings")  # fmt: skip
ENDED = (Status.DONE, Status.FAILED, Status.EXPIRED)
# An active episode's fields, enough to resolve it without reading it again.
ALERT_FIELDS = ("id", "rule_id", "vessel_id", "kind", "subject", "state", "opened_at",
                "acknowledged_at", "acknowledged_by", "detail", "value", "fix_id")  # fmt: skip


@dataclass
class PassReport:
    """What one pass did (run_alerts logs it; the bench and tests read it)."""

    rules: int = 0
    vessels: int = 0
    fixes: int = 0
    opened: int = 0
    resolved: int = 0
    failed_rules: list[int] = field(default_factory=list)


class PushAside:
    """Rules that failed: when each may be tried again (healthchecks' "don't trip on this check
    again for an hour"), on a monotonic clock."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.failures: dict[int, tuple[int, float]] = {}

    def skips(self, rule_id: int) -> bool:
        failures, retry_at = self.failures.get(rule_id, (0, 0.0))
        return bool(failures) and self.clock() < retry_at

    def failed(self, rule_id: int) -> float:
        failures = self.failures.get(rule_id, (0, 0.0))[0] + 1
        delay = after_failures(RETRY_FIRST_S, failures - 1, cap=RETRY_MAX_S,
                               max_doublings=UNTIL_THE_CAP)  # fmt: skip
        self.failures[rule_id] = (failures, self.clock() + delay)
        return delay

    def worked(self, rule_id: int) -> None:
        self.failures.pop(rule_id, None)


@dataclass
class Snapshot:
    """What one pass read, shared by the rules."""

    now: dt.datetime
    vessels: dict[int, dict[str, Any]]
    by_kind: dict[str, list[int]]
    # Rule id -> (vessel id, subject) -> the active episode's row.
    active: dict[int, dict[tuple[int, str], dict[str, Any]]]
    fixes: dict[int, list[tuple[Any, ...]]]
    channels: dict[str, tuple[float | None, float | None]]
    commands: list[dict[str, Any]]
    # Fence id -> (lat, lon) -> inside it? (judge_fence: shared by the rules on one fence).
    inside: dict[int, dict[tuple[float, float], bool]] = field(default_factory=dict)
    # (vessel id, transport) -> spent today, in the budget's units (budget rules only).
    spent: dict[tuple[int, str], float] = field(default_factory=dict)

    def scope(self, rule: AlertRule) -> list[int]:
        if rule.vessel_id is not None:
            v = self.vessels.get(rule.vessel_id)
            return (
                [rule.vessel_id]
                if v and (not rule.vessel_kind or v["kind"] == rule.vessel_kind)
                else []
            )
        if rule.vessel_kind:
            return self.by_kind.get(rule.vessel_kind, [])
        return list(self.vessels)


class Evaluator:
    """Holds the cursors between passes; ``run_pass`` is one pass (module docstring)."""

    def __init__(
        self,
        *,
        since: dt.datetime | None = None,
        overlap_s: float | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        start = since or timezone.now()
        self.overlap = dt.timedelta(
            seconds=settings.ALERTS_FIX_OVERLAP_S if overlap_s is None else overlap_s
        )
        self.fix_cursor = start
        self.command_cursor = start - COMMAND_LOOKBACK
        # Fix id -> received_at, for the fixes judged within the overlap window.
        self.seen: dict[int, dt.datetime] = {}
        # Vessel id -> (hour the means were read in, hour start -> mean battery volts).
        self.hourly: dict[int, tuple[int, dict[int, float]]] = {}
        # Vessel id -> empty volts -> endurance hours, for the hour of self.hourly.
        self.estimates: dict[int, dict[float, float | None]] = {}
        self.aside = PushAside(clock)

    # The pass -----------------------------------------------------------------------------

    def run_pass(self, now: dt.datetime | None = None) -> PassReport:
        now = now or timezone.now()
        report = PassReport()
        rules = [r for r in active_rules() if not self.aside.skips(r.pk)]
        snap = self.snapshot(rules, now)
        report.rules, report.vessels = len(rules), len(snap.vessels)
        report.fixes = sum(len(f) for f in snap.fixes.values())
        for rule in rules:
            try:
                opened, resolved = self.judge(rule, snap)
            except Exception:
                delay = self.aside.failed(rule.pk)
                logger.exception("run_alerts: rule %s (%s) failed; skipping it for %.0f s",
                                 rule.pk, rule.name, delay)  # fmt: skip
                report.failed_rules.append(rule.pk)
                continue
            self.aside.worked(rule.pk)
            report.opened += opened
            report.resolved += resolved
        self.advance(snap, now)
        return report

    def snapshot(self, rules: list[AlertRule], now: dt.datetime) -> Snapshot:
        kinds = {r.kind for r in rules}
        vessels = {
            v["id"]: v
            for v in Vessel.objects.filter(active=True).values(
                "id", "slug", "kind", "telemetry_period_s", "last_seen_at", *BUDGET_FIELDS.values()
            )
        }
        by_kind: dict[str, list[int]] = defaultdict(list)
        for v in vessels.values():
            by_kind[v["kind"]].append(v["id"])
        active: dict[int, dict[tuple[int, str], dict[str, Any]]] = defaultdict(dict)
        for a in Alert.objects.filter(state__in=ACTIVE_STATES).values(*ALERT_FIELDS):
            active[a["rule_id"]][(a["vessel_id"], a["subject"])] = a
        fixes = self.new_fixes() if kinds & set(FIX_RULES) else {}
        channels = {}
        if RuleKind.READING in kinds:
            channels = {
                c["key"]: (c["minimum"], c["maximum"])
                for c in SensorChannel.objects.values("key", "minimum", "maximum")
            }
        commands = self.ended_commands() if RuleKind.COMMAND in kinds else []
        spent = spent_today(now) if RuleKind.BUDGET in kinds else {}
        return Snapshot(now, vessels, by_kind, active, fixes, channels, commands, spent=spent)

    def new_fixes(self) -> dict[int, list[tuple[Any, ...]]]:
        """Fixes received since the last pass (less the overlap), not judged yet, per vessel in
        time order. Uses the index on received_at (telemetry migration 0003)."""
        window = Fix.objects.filter(received_at__gte=self.fix_cursor - self.overlap)
        # Ids first, then the rows of the new ones only: the window holds ALERTS_FIX_OVERLAP_S
        # of the fleet's fixes, most of them judged already, and converting their dates and
        # readings was most of a pass under heavy ingest (bench.alerts). A fix committed
        # between the two reads is in the next pass's window.
        ids = list(window.values_list("id", flat=True))
        fresh = [pk for pk in ids if pk not in self.seen]
        rows: list[tuple[Any, ...]] = []
        if len(fresh) * 2 > len(ids):  # mostly new (a first pass): one read of the window
            rows = [row for row in window.values_list(*FIX_FIELDS) if row[0] not in self.seen]
        else:
            for chunk in _chunks(fresh, 500):  # SQLite's bound-parameter limit
                rows.extend(Fix.objects.filter(pk__in=chunk).values_list(*FIX_FIELDS))
        rows.sort(key=lambda row: row[2])  # recorded_at: each vessel's fixes in time order
        fixes: dict[int, list[tuple[Any, ...]]] = defaultdict(list)
        for row in rows:
            fixes[row[1]].append(row)
        return fixes

    def ended_commands(self) -> list[dict[str, Any]]:
        return list(
            Command.objects.filter(
                finished_at__gte=self.command_cursor - self.overlap, status__in=ENDED
            )
            .order_by("finished_at")
            .values("uid", "vessel_id", "kind", "status", "created_at", "result_detail")
        )

    def advance(self, snap: Snapshot, now: dt.datetime) -> None:
        """Move the cursors to this pass's start; note the fixes judged (only now: a pass that
        failed before judging them leaves them to the next); forget ids older than the overlap
        window, which the next pass does not read again."""
        self.fix_cursor = self.command_cursor = now
        horizon = now - self.overlap
        self.seen = {pk: at for pk, at in self.seen.items() if at >= horizon}
        for rows in snap.fixes.values():
            self.seen.update((row[0], row[3]) for row in rows if row[3] >= horizon)

    # Judging one rule -----------------------------------------------------------------------

    def judge(self, rule: AlertRule, snap: Snapshot) -> tuple[int, int]:
        """Open and resolve ``rule``'s episodes on the vessels it covers: (opened, resolved)."""
        judge = getattr(self, f"judge_{rule.kind}")
        episodes = Episodes(rule, snap)
        judge(rule, snap, episodes)
        episodes.apply()
        return episodes.opened, episodes.resolved

    def judge_overdue(self, rule: AlertRule, snap: Snapshot, ep: Episodes) -> None:
        for vessel_id in snap.scope(rule):
            v = snap.vessels[vessel_id]
            limit = R.overdue_limit_s(v["telemetry_period_s"], rule.threshold)
            seen = v["last_seen_at"]
            silent = (snap.now - seen).total_seconds() if seen else None
            verdict = R.overdue(silent, limit)
            if ep.changes(vessel_id, verdict):
                detail = f"silent {silent:.0f} s (limit {limit:.0f} s)"
                ep.observe(vessel_id, verdict, value=silent, detail=detail)

    def judge_battery(self, rule: AlertRule, snap: Snapshot, ep: Episodes) -> None:
        if rule.threshold is None:
            return
        threshold, clear = rule.threshold, R.battery_clear_v(rule.threshold, rule.maximum)
        for vessel_id in snap.scope(rule):
            fixes = snap.fixes.get(vessel_id)
            if not fixes:
                continue
            active = ep.is_active(vessel_id)
            for fix in fixes:
                volts = fix[6]
                # Past the fixes that cannot change the episode without asking the rule (most:
                # battery() holds only below threshold, clears only above clear; the column
                # holds floats or None; NaN and infinities take the long way to KEEP).
                if volts is None or (volts <= clear if active else volts >= threshold):
                    continue
                verdict = R.battery(volts, rule.threshold, rule.maximum)
                if ep.changes(vessel_id, verdict):
                    detail = f"battery {volts} V, below {rule.threshold} V"
                    ep.observe(vessel_id, verdict, value=volts, detail=detail, fix_id=fix[0])
                    active = ep.is_active(vessel_id)

    def judge_reading(self, rule: AlertRule, snap: Snapshot, ep: Episodes) -> None:
        low, high = snap.channels.get(rule.reading, (None, None))
        limits = R.reading_limits(rule.minimum, rule.maximum, low, high)
        if not limits.usable:
            return
        key, low, high = rule.reading, limits.low, limits.high
        for vessel_id in snap.scope(rule):
            fixes = snap.fixes.get(vessel_id)
            if not fixes:
                continue
            active = ep.is_active(vessel_id)
            for fix in fixes:
                value = (fix[7] or {}).get(key)
                # Past the values that cannot open an episode without asking the rule (most:
                # a plain number within the limits; anything else takes the long way).
                if value is None or (
                    not active
                    and type(value) in (int, float)
                    and (low is None or value >= low)
                    and (high is None or value <= high)
                ):
                    continue
                verdict = R.reading(value, limits)
                if ep.changes(vessel_id, verdict):
                    detail = f"{rule.reading} {value}, outside {limits.low} … {limits.high}"
                    ep.observe(vessel_id, verdict, value=_num(value), detail=detail,
                               fix_id=fix[0])  # fmt: skip
                    active = ep.is_active(vessel_id)

    def judge_fence(self, rule: AlertRule, snap: Snapshot, ep: Episodes) -> None:
        fence = rule.fence
        if fence is None:
            return
        # The contract's shape and geometry: what the boat's autopilot holds (docs/alerts.md).
        wire = wire_fence(id=fence.pk, name=fence.name, inclusion=fence.inclusion,
                          geometry=fence.geometry, radius_m=fence.radius_m)  # fmt: skip

        # Rules on one fence share its answers within a pass (probe points included).
        known = snap.inside.setdefault(fence.pk, {})
        test = containment(wire)

        def inside(lat: float, lon: float) -> bool:
            answer = known.get((lat, lon))
            if answer is None:
                answer = known[(lat, lon)] = test(lat, lon)
            return answer

        side = "outside" if fence.inclusion else "inside"
        detail = f"{side} {'inclusion' if fence.inclusion else 'exclusion'} fence {fence.name}"
        for vessel_id in snap.scope(rule):
            if fence.vessel_id is not None and fence.vessel_id != vessel_id:
                continue
            for fix in snap.fixes.get(vessel_id, ()):
                active = ep.is_active(vessel_id)
                if not active and inside(fix[4], fix[5]) == fence.inclusion:
                    continue  # allowed, and nothing to clear: fence() would say KEEP
                verdict = R.fence(fix[4], fix[5], fence.inclusion, inside, need_clear=active)
                if ep.changes(vessel_id, verdict):
                    ep.observe(vessel_id, verdict, fix_id=fix[0],
                               detail=f"{detail} at {fix[4]:.5f}, {fix[5]:.5f}")  # fmt: skip

    def judge_endurance(self, rule: AlertRule, snap: Snapshot, ep: Episodes) -> None:
        if rule.threshold is None:
            return
        empty = rule.minimum if rule.minimum is not None else settings.ALERTS_BATTERY_EMPTY_V
        vessels = snap.scope(rule)
        for vessel_id, hours in self.endurance(vessels, empty, snap.now).items():
            verdict = R.endurance(hours, rule.threshold)
            if ep.changes(vessel_id, verdict):
                value = None if hours is None or math.isinf(hours) else round(hours, 2)
                detail = f"endurance {value} h to {empty} V, below {rule.threshold} h"
                ep.observe(vessel_id, verdict, value=value, detail=detail)

    def endurance(self, vessel_ids: list[int], empty: float, now: dt.datetime) -> dict[int, Any]:
        """Each vessel's endurance to ``empty`` volts: computed once per clock hour, since the
        hourly means it comes from change only when an hour ends."""
        means = self.hourly_means(vessel_ids, now)
        answers = {}
        for vessel_id in vessel_ids:
            cache = self.estimates.setdefault(vessel_id, {})
            if empty not in cache:
                cache[empty] = endurance_hours(means[vessel_id], empty_v=empty,
                                               now_s=now.timestamp())  # fmt: skip
            answers[vessel_id] = cache[empty]
        return answers

    def hourly_means(self, vessel_ids: list[int], now: dt.datetime) -> dict[int, dict[int, float]]:
        """Each vessel's hourly battery means (two days), brought up to date once per clock
        hour: a vessel seen before has only its last REREAD_HOURS read again (the overview
        loop may rebuild a recent hour after late fixes); a new one all ENDURANCE_HOURS."""
        hour = math.floor(now.timestamp() / HOUR_S) * HOUR_S
        stale = [v for v in vessel_ids if self.hourly.get(v, (None,))[0] != hour]
        if not stale:
            return {v: self.hourly[v][1] for v in vessel_ids}
        oldest = hour - ENDURANCE_HOURS * HOUR_S
        known = [v for v in stale if v in self.hourly]
        since = {v: oldest for v in stale if v not in self.hourly}
        for v in known:
            since[v] = max(oldest, self.hourly[v][0] - REREAD_HOURS * HOUR_S)
        rows: dict[int, list[tuple[int, Any]]] = defaultdict(list)
        for start in set(since.values()):
            group = [v for v in stale if since[v] == start]
            for chunk in _chunks(group, 500):  # SQLite's bound-parameter limit
                buckets = TrackBucket.objects.filter(
                    vessel_id__in=chunk, width=HOUR_S, start__gte=start, start__lt=hour
                ).values_list("vessel_id", "start", "channels")
                for vessel_id, bucket_start, channels in buckets:
                    rows[vessel_id].append((bucket_start, channels))
        for v in stale:
            means = self.hourly[v][1] if v in self.hourly else {}
            means = {t: m for t, m in means.items() if oldest <= t < since[v]}
            means.update(hourly_means_from_channels(rows[v]))
            self.hourly[v] = (hour, means)
            self.estimates.pop(v, None)
        return {v: self.hourly[v][1] for v in vessel_ids}

    def judge_budget(self, rule: AlertRule, snap: Snapshot, ep: Episodes) -> None:
        """One episode per vessel and transport (its subject) over today's budget."""
        transports = [rule.reading] if rule.reading else list(BUDGET_FIELDS)
        for vessel_id in snap.scope(rule):
            for transport in (t for t in transports if t in BUDGET_FIELDS):
                limit = budget_limit(snap.vessels[vessel_id], transport, rule.threshold)
                spent = snap.spent.get((vessel_id, transport), 0.0)
                verdict = R.budget(spent, limit)
                if ep.changes(vessel_id, verdict, subject=transport):
                    unit = R.BUDGET_UNITS[transport]
                    detail = f"{transport}: {spent:g} {unit} today, over the budget of {limit:g}"
                    ep.observe(vessel_id, verdict, subject=transport, value=spent, detail=detail)

    def judge_command(self, rule: AlertRule, snap: Snapshot, ep: Episodes) -> None:
        """A failed or expired command opens an episode of its own (subject: its uid), once
        ever; a later command of the same kind to the same vessel that ends done resolves it."""
        scope = set(snap.scope(rule))
        ended = [c for c in snap.commands if c["vessel_id"] in scope]
        bad = [c for c in ended if c["status"] in R.COMMAND_BAD_ENDS]
        done = [c for c in ended if c["status"] == Status.DONE]
        if bad:
            ever = set(
                Alert.objects.filter(rule=rule, subject__in=[str(c["uid"]) for c in bad])
                .values_list("subject", flat=True)
            )  # fmt: skip
            for c in bad:
                if str(c["uid"]) in ever:
                    continue
                detail = f"{c['kind']} {c['status']}" + (
                    f": {c['result_detail']}" if c["result_detail"] else ""
                )
                ep.open(c["vessel_id"], str(c["uid"]), detail=detail)
        if done:
            self.resolve_commands(rule, snap, ep, done)

    def resolve_commands(
        self, rule: AlertRule, snap: Snapshot, ep: Episodes, done: list[dict[str, Any]]
    ) -> None:
        open_uids = [s for (_, s) in snap.active.get(rule.pk, {}) if s]
        if not open_uids:
            return
        failed = Command.objects.filter(uid__in=open_uids).values("uid", "vessel_id", "kind",
                                                                    "created_at")  # fmt: skip
        for f in failed:
            later = [
                d for d in done
                if d["vessel_id"] == f["vessel_id"] and d["kind"] == f["kind"]
                and d["created_at"] > f["created_at"]
            ]  # fmt: skip
            if later:
                ep.resolve(f["vessel_id"], str(f["uid"]), detail=f"{later[0]['uid']} done")


class Episodes:
    """One rule's episodes during a pass: state per (vessel, subject) as judged, and the
    transitions to write (apply)."""

    def __init__(self, rule: AlertRule, snap: Snapshot) -> None:
        self.rule, self.snap = rule, snap
        self.opened = self.resolved = 0
        # (vessel, subject) -> its active episode's row from the snapshot, or an Opening.
        self.live: dict[tuple[int, str], Any] = dict(snap.active.get(rule.pk, {}))
        self.intents: list[Opening | Resolving] = []

    def is_active(self, vessel_id: int, subject: str = "") -> bool:
        return (vessel_id, subject) in self.live

    def changes(self, vessel_id: int, verdict: R.Verdict, subject: str = "") -> bool:
        """Would ``verdict`` open or resolve an episode? (The cheap question asked per fix.)"""
        return verdict is (R.CLEARS if (vessel_id, subject) in self.live else R.HOLDS)

    def observe(
        self,
        vessel_id: int,
        verdict: R.Verdict,
        *,
        subject: str = "",
        value: float | None = None,
        detail: str = "",
        fix_id: int | None = None,
    ) -> None:
        active = (vessel_id, subject) in self.live
        _, change = R.step(active, verdict)
        if change == "open":
            self.open(vessel_id, subject, value=value, detail=detail, fix_id=fix_id)
        elif change == "resolve":
            self.resolve(vessel_id, subject)

    def open(self, vessel_id: int, subject: str, **fields: Any) -> None:
        opening = Opening(vessel_id, subject, fields)
        self.live[(vessel_id, subject)] = opening
        self.intents.append(opening)

    def resolve(self, vessel_id: int, subject: str, detail: str = "") -> None:
        live = self.live.pop((vessel_id, subject), None)
        if live is not None:
            self.intents.append(Resolving(live, detail))

    def apply(self) -> None:
        """Write the rule's transitions, in the order judged, in one transaction: a busy pass
        commits once per rule, not once per episode (bench.alerts: a commit is most of an
        episode's cost). Each open is a savepoint of its own, so losing a race to another
        evaluator (the unique constraint) costs only that one; a resolve is a conditional
        UPDATE. Judging wrote nothing, so the transaction (SQLite's write lock) lasts only as
        long as the writes."""
        if not self.intents:
            return
        with transaction.atomic():
            for intent in self.intents:
                if isinstance(intent, Opening):
                    self._open(intent)
                else:
                    self._resolve(intent)

    def _open(self, opening: Opening) -> None:
        v, s = opening.vessel_id, opening.subject
        alert = alert_open(rule=self.rule, vessel_id=v, subject=s, now=self.snap.now,
                           **opening.fields)  # fmt: skip
        if alert is None:  # another evaluator opened it first: it is live all the same
            alert = Alert.objects.filter(
                rule=self.rule, vessel_id=v, subject=s, state__in=ACTIVE_STATES
            ).first()
        else:
            self.opened += 1
        opening.alert = alert

    def _resolve(self, resolving: Resolving) -> None:
        live = resolving.live
        if isinstance(live, Opening):
            alert = live.alert  # opened earlier in this pass (None: it could not be)
        else:
            alert = Alert(**live)
            alert.rule = self.rule  # its channels are prefetched
        if alert is None:
            return
        if alert_resolve(alert=alert, now=self.snap.now, detail=resolving.detail):
            self.resolved += 1


@dataclass
class Opening:
    """An episode to open (Episodes.apply), and then the Alert it became."""

    vessel_id: int
    subject: str
    fields: dict[str, Any]
    alert: Alert | None = None


@dataclass
class Resolving:
    """An episode to resolve: its row from the snapshot, or an Opening of this pass."""

    live: Any
    detail: str = ""


def active_rules() -> list[AlertRule]:
    rules = AlertRule.objects.filter(active=True).select_related("fence")
    return list(rules.prefetch_related("channels").order_by("pk"))


def _num(value: Any) -> float | None:
    return float(value) if R.is_number(value) else None


def _chunks(items: list[int], size: int) -> Iterable[list[int]]:
    for i in range(0, len(items), size):
        yield items[i : i + size]
