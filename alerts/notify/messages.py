"""What an alert event says on each kind of channel: the webhook's JSON, an e-mail, one SMS.

Pure: reads the alert's attributes (``vessel``, ``rule`` and the episode's fields) and does no
I/O. The webhook's shape is a contract (docs/alerts.md, "Webhooks"); the texts are for people
woken at night, so the first words say what and where: ``ALERT spab 03:12Z Overdue: …``.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Sequence
from typing import Any

from sms import gsm7

from .base import Message

OPENED, ACKNOWLEDGED, RESOLVED = "alert.opened", "alert.acknowledged", "alert.resolved"
EVENTS = (OPENED, ACKNOWLEDGED, RESOLVED)
# The first word of a text: short, and distinct at a glance on a lock screen.
VERB = {OPENED: "ALERT", ACKNOWLEDGED: "ACK", RESOLVED: "CLEAR"}
PAST = {OPENED: "opened", ACKNOWLEDGED: "acknowledged", RESOLVED: "resolved"}
SUBJECT_PREFIX = "[Shoreside]"
# GSM-7 extension characters cost two septets and some cannot be typed in text mode at all
# (sms.modem.driver: ESC and Ctrl-Z bytes), so texts spell them plainly.
_PLAIN = str.maketrans({"{": "(", "}": ")", "[": "(", "]": ")", "~": "-", "|": "/",
                        "\\": "/", "^": "'", "€": "EUR", "\f": " ", "Ξ": "Xi"})  # fmt: skip
_ELLIPSIS = "..."


def iso(when: dt.datetime | None) -> str | None:
    """RFC 3339 in UTC with a ``Z``, as the API writes times; None stays None."""
    if when is None:
        return None
    return when.astimezone(dt.UTC).isoformat().replace("+00:00", "Z")


def payload(event: str, alert: Any) -> dict[str, Any]:
    """The webhook body: exactly ``{"event", "alert": {…}}`` (docs/alerts.md, "Webhooks")."""
    return {
        "event": event,
        "alert": {
            "id": alert.pk,
            "vessel": alert.vessel.slug,
            "rule": alert.rule.name,
            "kind": alert.kind,
            "state": alert.state,
            "opened_at": iso(alert.opened_at),
            "acknowledged_at": iso(alert.acknowledged_at),
            "acknowledged_by": alert.acknowledged_by or None,
            "resolved_at": iso(alert.resolved_at),
            "detail": alert.detail,
        },
    }


def event_time(event: str, alert: Any) -> dt.datetime:
    """When the event happened (the opening time if the alert has moved on since)."""
    when = {ACKNOWLEDGED: alert.acknowledged_at, RESOLVED: alert.resolved_at}.get(event)
    return when or alert.opened_at


def _clock(when: dt.datetime) -> str:
    return when.astimezone(dt.UTC).strftime("%H:%MZ")


def _stamp(when: dt.datetime | None) -> str:
    return when.astimezone(dt.UTC).strftime("%Y-%m-%d %H:%M:%S UTC") if when else "-"


def fit_sms(text: str) -> str:
    """``text`` as one SMS a text-mode modem can type: GSM-7 basic characters only (no UCS-2,
    which would cut the length to 70), at most 160 of them, cut with ``...`` when longer."""
    plain = gsm7.to_gsm7(" ".join(text.translate(_PLAIN).split()))
    if len(plain) <= gsm7.SMS_SEPTETS:
        return plain
    return plain[: gsm7.SMS_SEPTETS - len(_ELLIPSIS)].rstrip() + _ELLIPSIS


def sms_text(event: str, alert: Any) -> str:
    """``ALERT spab 03:12Z Overdue: silent 25 min`` (an ack names who), fitted to one SMS."""
    head = f"{VERB[event]} {alert.vessel.slug} {_clock(event_time(event, alert))} {alert.rule.name}"
    if event == ACKNOWLEDGED:
        tail = f" by {alert.acknowledged_by}" if alert.acknowledged_by else ""
    else:
        tail = f": {alert.detail}" if alert.detail else ""
    return fit_sms(head + tail)


def single(event: str, alert: Any) -> Message:
    """The message for one alert event on any channel."""
    vessel = f"{alert.vessel.name} ({alert.vessel.slug})"
    subject = f"{SUBJECT_PREFIX} {VERB[event]} {vessel}: {alert.rule.name}"
    lines = [
        f"Alert {PAST[event]}: {alert.rule.name} on {vessel}.",
        "",
        f"Rule:          {alert.rule.name} ({alert.kind})",
        f"State:         {alert.state}",
        f"Opened:        {_stamp(alert.opened_at)}",
        f"Acknowledged:  {_stamp(alert.acknowledged_at)}"
        + (f" by {alert.acknowledged_by}" if alert.acknowledged_by else ""),
        f"Resolved:      {_stamp(alert.resolved_at)}",
        f"Detail:        {alert.detail or '-'}",
        "",
        f"Alert #{alert.pk}.",
    ]
    return Message(
        event=event,
        subject=" ".join(subject.split()),
        body="\n".join(lines) + "\n",
        sms=sms_text(event, alert),
        payload=payload(event, alert),
    )


def summary(event: str, alerts: Sequence[Any]) -> Message:
    """One message for many alerts of one event (a flood): the vessels grouped by rule.

    The SMS names as many vessels as fit and counts the rest (``+12 more``); the e-mail lists
    every alert on its own line.
    """
    when = min(event_time(event, alert) for alert in alerts)
    by_rule: dict[str, list[str]] = {}
    for alert in alerts:
        by_rule.setdefault(alert.rule.name, []).append(alert.vessel.slug)
    rules = ", ".join(by_rule)
    subject = f"{SUBJECT_PREFIX} {VERB[event]} x{len(alerts)}: {len(alerts)} alerts {PAST[event]}"
    lines = [f"{len(alerts)} alerts {PAST[event]} ({rules}), first at {_stamp(when)}:", ""]
    for alert in alerts:
        at = _stamp(event_time(event, alert))
        line = f"- {alert.vessel.slug}: {alert.rule.name}, {at}"
        lines.append(line + (f": {alert.detail}" if alert.detail else ""))
    lines += ["", "Alert numbers: " + ", ".join(f"#{alert.pk}" for alert in alerts) + "."]
    return Message(
        event=event,
        subject=f"{subject} ({rules})",
        body="\n".join(lines) + "\n",
        sms=_summary_sms(f"{VERB[event]} x{len(alerts)} {_clock(when)}", by_rule),
    )


def _summary_sms(head: str, by_rule: dict[str, list[str]]) -> str:
    """``ALERT x20 03:12Z Overdue: a, b, c; Battery: d +12 more``, as much as one SMS holds."""
    total = sum(len(slugs) for slugs in by_rule.values())
    text, named = fit_sms(head), 0
    for rule, slugs in by_rule.items():
        for i, slug in enumerate(slugs):
            piece = (f"; {rule}: " if named else f" {rule}: ") if i == 0 else ", "
            more = f" +{total - named - 1} more" if named + 1 < total else ""
            candidate = fit_sms(text + piece + slug)
            if len(candidate + more) > gsm7.SMS_SEPTETS or candidate.endswith(_ELLIPSIS):
                return fit_sms(f"{text} +{total - named} more")
            text, named = candidate, named + 1
    return text
