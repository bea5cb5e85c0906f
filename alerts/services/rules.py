"""Writes for alert rules: create, change, delete, each checked for its kind and recorded in the
audit log ("rule.created", "rule.changed", "rule.deleted") in its own transaction.

What a rule needs, by kind (docs: the alert-rules API):

- overdue: ``threshold``, the number of the vessel's own telemetry periods of silence;
- battery: ``threshold``, volts;
- endurance: ``threshold``, hours left until the battery is empty;
- reading: ``reading`` (a reading key) and ``minimum`` and/or ``maximum``, or neither when
  the key's SensorChannel has limits (the defaults);
- fence: ``fence``;
- command: nothing more.

A field another kind uses is refused by name rather than kept unused: a rule says what it
watches and nothing else.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from django.core.exceptions import ValidationError
from django.db import transaction

from alerts.models import AlertRule, NotificationChannel, RuleKind
from alerts.rules import BUDGET_UNITS
from audit.services import audit_changes, audit_record, audit_snapshot
from telemetry.models import SensorChannel

THRESHOLD_MEANS = {
    RuleKind.OVERDUE: "telemetry periods of silence",
    RuleKind.BATTERY: "volts",
    RuleKind.ENDURANCE: "hours",
}
RULE_FIELDS = (
    "name", "vessel", "vessel_kind", "kind", "threshold", "reading", "minimum", "maximum",
    "fence", "active",
)  # fmt: skip


def _finite(value: Any) -> bool:
    return value is None or math.isfinite(value)


def rule_problems(rule: AlertRule) -> dict[str, list[str]]:
    """What is wrong with ``rule`` for its kind, by field ({} when nothing is)."""
    problems: dict[str, list[str]] = {}

    def say(field: str, message: str) -> None:
        problems.setdefault(field, []).append(message)

    kind = rule.kind
    for field in ("threshold", "minimum", "maximum"):
        if not _finite(getattr(rule, field)):
            say(field, "must be a finite number")
    if kind in THRESHOLD_MEANS:
        if rule.threshold is None:
            say("threshold", f"a {kind} rule needs a threshold ({THRESHOLD_MEANS[kind]})")
        elif rule.threshold <= 0:
            say("threshold", f"must be above 0 ({THRESHOLD_MEANS[kind]})")
    elif kind == RuleKind.BUDGET:
        if rule.threshold is not None and rule.threshold <= 0:
            say("threshold", "must be above 0 (the budget of a vessel without its own)")
    elif rule.threshold is not None:
        say("threshold", f"a {kind} rule has no threshold")
    if kind == RuleKind.READING:
        _reading_problems(rule, say)
    elif kind == RuleKind.BUDGET:
        if rule.reading and rule.reading not in BUDGET_UNITS:
            say("reading", f"a budget rule's transport is one of {', '.join(BUDGET_UNITS)}")
        for field in ("minimum", "maximum"):
            if getattr(rule, field) is not None:
                say(field, f"only a reading rule has a {field}")
    else:
        for field in ("reading", "minimum", "maximum"):
            if getattr(rule, field) not in (None, ""):
                say(field, f"only a reading rule has a {field}")
    if kind == RuleKind.FENCE:
        if rule.fence_id is None:
            say("fence", "a fence rule needs a fence")
        elif rule.fence.vessel_id and rule.vessel_id and rule.fence.vessel_id != rule.vessel_id:
            say("fence", f"the fence {rule.fence} belongs to another vessel")
    elif rule.fence_id is not None:
        say("fence", "only a fence rule has a fence")
    if rule.vessel_id and rule.vessel_kind and rule.vessel.kind != rule.vessel_kind:
        say("vessel_kind", f"{rule.vessel} is not of this kind: leave it empty for one vessel")
    return problems


def _reading_problems(rule: AlertRule, say: Any) -> None:
    if not rule.reading:
        say("reading", "a reading rule needs the reading's key (e.g. hull_humidity_pct)")
        return
    low, high = rule.minimum, rule.maximum
    if low is not None and high is not None and low >= high:
        say("maximum", "must be above the minimum")
    if low is None and high is None:
        channel = SensorChannel.objects.filter(key=rule.reading).first()
        if channel is None or (channel.minimum is None and channel.maximum is None):
            say(
                "minimum",
                f"give a minimum or a maximum: the sensor channel {rule.reading!r} has no limits "
                "to use instead",
            )


def _check(rule: AlertRule) -> None:
    rule.full_clean()
    problems = rule_problems(rule)
    if problems:
        raise ValidationError(problems)


def _audit(
    rule: AlertRule, action: str, *, by: str, via: str, ip: str | None, **detail: Any
) -> None:
    audit_record(
        action=action,
        actor=by,
        via=via,
        ip=ip,
        subject_type="alert_rule",
        subject_id=rule.pk,
        subject=f"{rule.name} ({rule.kind})",
        vessel=rule.vessel.slug if rule.vessel_id else "",
        detail=detail,
    )


def _summary(rule: AlertRule) -> dict[str, Any]:
    return audit_snapshot(rule, RULE_FIELDS)


@transaction.atomic
def alert_rule_create(
    *,
    fields: Mapping[str, Any],
    channels: Iterable[NotificationChannel] = (),
    by: str = "",
    via: str = "",
    ip: str | None = None,
) -> AlertRule:
    """A new rule from ``fields`` (names in RULE_FIELDS), telling ``channels``; raises
    ValidationError naming each field that is wrong for its kind."""
    unknown = set(fields) - set(RULE_FIELDS)
    if unknown:
        raise ValueError(f"alert_rule_create cannot set {', '.join(sorted(unknown))}")
    rule = AlertRule(**fields)
    _check(rule)
    rule.save()
    rule.channels.set(list(channels))
    _audit(rule, "rule.created", by=by, via=via, ip=ip, settings=_summary(rule),
           channels=sorted(c.pk for c in channels))  # fmt: skip
    return rule


@transaction.atomic
def alert_rule_update(
    *,
    rule: AlertRule,
    fields: Mapping[str, Any],
    channels: Iterable[NotificationChannel] | None = None,
    by: str = "",
    via: str = "",
    ip: str | None = None,
) -> AlertRule:
    """Change ``fields`` of ``rule`` (and its channels, unless None), checked as a whole
    rule: a PATCH of the kind alone must still leave a rule its kind can run."""
    unknown = set(fields) - set(RULE_FIELDS)
    if unknown:
        raise ValueError(f"alert_rule_update cannot change {', '.join(sorted(unknown))}")
    before = _summary(rule)
    old_channels = sorted(rule.channels.values_list("pk", flat=True))
    for name, value in fields.items():
        setattr(rule, name, value)
    _check(rule)
    rule.save()
    if channels is not None:
        rule.channels.set(list(channels))
    after = _summary(rule)
    changed = audit_changes(before, after)
    new_channels = sorted(rule.channels.values_list("pk", flat=True))
    if new_channels != old_channels:
        changed["channels"] = {"from": old_channels, "to": new_channels}
    if changed:
        _audit(rule, "rule.changed", by=by, via=via, ip=ip, changed=changed)
    return rule


@transaction.atomic
def alert_rule_delete(
    *, rule: AlertRule, by: str = "", via: str = "", ip: str | None = None
) -> None:
    """Delete a rule and its alerts (they cascade); the audit entry keeps what it was."""
    _audit(rule, "rule.deleted", by=by, via=via, ip=ip, settings=_summary(rule))
    rule.delete()
