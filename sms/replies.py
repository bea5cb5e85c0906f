"""Replies that say what really happened: a command's outcome as an SMS reply shows it.

References: issue 11 §3 (``#FHEAD 230 OK``, ``#FHEAD 230 FAILED invalid data``; ``QUEUED`` when
the reply window passes, then one more SMS when the command ends); docs/wave-glider.md (a NAK goes
back to the sender, never silently); ``sms.bridge.commands`` (the reason of a failed command: its
failed event's ``cc_reason``, the NAK code's meaning or the inner command table's refusal, as
the bridge recorded it; else the command's result_detail as written, e.g. ``no answer from the
C&C box``).

A held reply keeps its answers as JSON (``SmsMessage.parsed`` of the outgoing message):
``{"echo", "outcome", "error", "note", "command"}`` where ``command`` is the pk of the command
whose outcome replaces ``outcome`` once it ends (``note`` stays after it). Pure: no Django, no I/O.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Mapping, Sequence
from typing import Any

from edge_client.contract.status import Status
from sms.language import Answer, compose_reply

QUEUED = "QUEUED"
OK = "OK"
FAILED = "FAILED"
# What a reply says for each final status (the contract's FINAL); the others (queued, sent,
# acknowledged) are still on their way.
ENDED = {Status.DONE: OK, Status.FAILED: FAILED, Status.CANCELLED: "CANCELLED",
         Status.SUPERSEDED: "SUPERSEDED", Status.EXPIRED: "EXPIRED"}  # fmt: skip


def command_outcome(status: str, detail: str = "", reason: str | None = None) -> str | None:
    """A command's outcome as a reply says it (``OK``, ``FAILED invalid data``), or None while
    it has not ended. A failure gives ``reason`` (the C&C's, recorded as a field) when there
    is one, else the command's ``detail`` as written: never a reason parsed out of prose."""
    word = ENDED.get(status)
    if word is None:
        return None
    if word != FAILED:
        return word
    said = (reason or detail).strip()
    return f"{FAILED} {said}" if said else FAILED


def answer_record(answer: Answer, command: int | None = None) -> dict[str, Any]:
    """One answer of a held reply as stored JSON."""
    record: dict[str, Any] = {"echo": answer.echo, "outcome": answer.outcome}
    if answer.error:
        record["error"] = True
    if answer.note:
        record["note"] = answer.note
    if command is not None:
        record["command"] = command
    return record


def settle(
    records: Sequence[Mapping[str, Any]], outcomes: Mapping[int, str | None]
) -> tuple[str, bool]:
    """The reply text with each command's outcome where it has one, and whether every command
    has ended. ``outcomes`` maps command pk to :func:`command_outcome`; a command missing from
    it (deleted) reads as ended with its stored outcome."""
    answers: list[Answer] = []
    ended = True
    for record in records:
        outcome = str(record.get("outcome", ""))
        error = bool(record.get("error", False))
        pk = record.get("command")
        if isinstance(pk, int) and pk in outcomes:
            settled = outcomes[pk]
            if settled is None:
                ended = False
            else:
                outcome = settled
                error = settled.startswith(FAILED)
        note = str(record.get("note", ""))
        answers.append(Answer(str(record.get("echo", "")), outcome, error=error, note=note))
    return compose_reply(answers), ended


# The glider's readings as #STATUS gives them: (reading, label, format), in this order; others
# are left out (one SMS is short). Names: sms/bridge/sensor_layouts.toml.
_READINGS = (
    ("humidity_temp_c", "", "{:.1f}C"),
    ("humidity_pct", "", "{:.0f}%RH"),
    ("pressure_kpa", "", "{:.1f}kPa"),
    ("leak1", "leak ", "{:.0f}"),
    ("leak2", "/", "{:.0f}"),
)


def readings_text(readings: Mapping[str, Any]) -> str:
    """``21.3C 45%RH 101.3kPa leak 0/0`` from the readings present (numbers only)."""
    parts: list[str] = []
    for name, label, form in _READINGS:
        value = readings.get(name)
        if isinstance(value, int | float) and not isinstance(value, bool):
            text = label + form.format(value)
            if label == "/" and parts and parts[-1].startswith("leak "):
                parts[-1] += text
            else:
                parts.append(text.lstrip("/"))
    return " ".join(parts)


_WINDOW_UNITS = (("day", 86400), ("h", 3600), ("min", 60))


def _window(seconds: int) -> str:
    for unit, size in _WINDOW_UNITS:
        if seconds % size == 0:
            count = seconds // size
            return f"{count} {unit}{'s' if unit == 'day' and count != 1 else ''}"
    return f"{seconds} s"


def rate_limit_notice(*, limit: int, window_s: int, until: dt.datetime, now: dt.datetime) -> str:
    """The one SMS a number gets when it reaches the rate limit: the limit and when its texts
    are answered again, in UTC to the minute, rounded up so that the time given is never early
    (the date too when it is not today's)."""
    until = until.astimezone(dt.UTC)
    minute = until.replace(second=0, microsecond=0)
    if until > minute:
        minute += dt.timedelta(minutes=1)
    today = now.astimezone(dt.UTC).date()
    when = f"{minute:%H:%M} UTC" if minute.date() == today else f"{minute:%Y-%m-%d %H:%M} UTC"
    return (
        f"SMS limit reached ({limit} per {_window(window_s)}): texts are not answered until {when}."
    )
