"""The glider's position as one SMS: GSM-7 only and at most 160 septets, whatever the fix holds.

References: issue 20 §5 (the bridge texts its position to authorised numbers on a schedule);
:mod:`sms.gsm7` (the alphabet, septets). Pure: no Django, no I/O.

The message, its parts separated by one space, each optional part left out when unknown::

    Wave Glider 2026-11-28 11:30 UTC 36.80300,-121.78800 hdg 230 1.2kn batt 12.6V nav #FHEAD 230

the vessel's name, the fix's time in UTC to the minute (seconds dropped, never rounded up),
latitude and longitude to 5 decimals (~1 m), heading (degrees true, three digits), speed over
ground in knots, the battery, and the C&C's state as the bridge knows it. A value that cannot
be right (not finite, out of range) is left out; a position that cannot be right reads ``?``.

Everything but the name and the state has a bounded width (about 70 septets at most), so only
those two can make the text too long. When it is, it is shortened in this order, stopping as
soon as it fits:

1. the name is cut to :data:`NAME_MAX` septets (always, too long or not);
2. the state is cut to the room left, ending in ``..``; when it does not fit and less than
   :data:`STATE_MIN` septets are left, it is dropped;
3. the name is dropped;
4. the battery, the speed, then the heading are dropped;
5. the text is cut at 160 septets (cannot happen with the widths above: the guarantee holds
   anyway).
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass

from sms.gsm7 import SMS_SEPTETS, septets, to_gsm7
from vessels.display import KNOTS_PER_MPS

NAME_MAX = 24
STATE_MIN = 8
ELLIPSIS = ".."
_SPACES = re.compile(r"\s+")


@dataclass(frozen=True, slots=True)
class PositionReport:
    """What one position SMS says: a fix and what the bridge knows around it."""

    time: dt.datetime
    lat: float
    lon: float
    heading_deg: float | None = None
    speed_mps: float | None = None
    battery_v: float | None = None
    name: str = ""  # the vessel's
    state: str = ""  # the C&C's, as the bridge knows it ("nav #FHEAD 230")


def format_position(report: PositionReport) -> str:
    """``report`` as one SMS: GSM-7 only, at most 160 septets (shortened as the module says)."""
    name = _cut(_clean(report.name), NAME_MAX)
    state = _clean(report.state)
    core = [_time(report.time), f"{_degrees(report.lat, 90)},{_degrees(report.lon, 180)}"]
    extras = [
        _heading(report.heading_deg),
        _speed(report.speed_mps),
        _battery(report.battery_v),
    ]
    # 2. the state cut to the room the rest leaves, or dropped.
    text = _join(name, core, extras, "")
    room = SMS_SEPTETS - septets(text) - (1 if text else 0)
    if state and (septets(state) <= room or room >= STATE_MIN):
        return _join(name, core, extras, _cut(state, room))
    if septets(text) <= SMS_SEPTETS:
        return text
    # 3. then the name; 4. then battery, speed, heading (never reached with today's widths).
    name = ""
    for drop in (None, 2, 1, 0):
        if drop is not None:
            extras[drop] = ""
        text = _join(name, core, extras, "")
        if septets(text) <= SMS_SEPTETS:
            return text
    return _cut(text, SMS_SEPTETS)  # 5.


def _join(name: str, core: list[str], extras: list[str], state: str) -> str:
    return " ".join(part for part in (name, *core, *extras, state) if part)


def _clean(text: str) -> str:
    """Free text (a name, the state) on one line in GSM-7: line breaks and runs of blanks become
    one space; what GSM-7 cannot spell is spelled plainly or becomes ``?``."""
    gsm = to_gsm7(_SPACES.sub(" ", text or ""))
    return _SPACES.sub(" ", gsm.replace("\f", " ")).strip()


def _cut(text: str, limit: int) -> str:
    """``text`` in at most ``limit`` septets: cut, ending in ``..``, when longer."""
    if septets(text) <= limit:
        return text
    room = limit - len(ELLIPSIS)
    kept: list[str] = []
    used = 0
    for ch in text:
        cost = septets(ch)
        if used + cost > room:
            break
        kept.append(ch)
        used += cost
    return ("".join(kept).rstrip() + ELLIPSIS) if room > 0 else ELLIPSIS[: max(limit, 0)]


def _time(when: dt.datetime) -> str:
    """UTC to the minute; a time without a zone is taken as UTC."""
    if when.tzinfo is not None:
        try:
            when = when.astimezone(dt.UTC)
        except (OverflowError, ValueError):  # year 1 or 9999 pushed over the edge
            when = when.replace(tzinfo=None)
    return f"{when.year:04d}-{when.month:02d}-{when.day:02d} {when.hour:02d}:{when.minute:02d} UTC"


def _finite(value: object) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    try:
        number = float(value)
    except OverflowError:  # an int too big for a float
        return None
    return number if math.isfinite(number) else None


def _degrees(value: float, limit: int) -> str:
    number = _finite(value)
    if number is None or not -limit <= number <= limit:
        return "?"
    text = f"{number:.5f}"
    return "0.00000" if text == "-0.00000" else text


def _heading(value: float | None) -> str:
    number = _finite(value)
    if number is None:
        return ""
    return f"hdg {round(number % 360) % 360:03d}"


def _speed(value: float | None) -> str:
    number = _finite(value)
    if number is None or number < 0:
        return ""
    knots = round(number * KNOTS_PER_MPS, 1)
    return f"{knots:.1f}kn" if knots < 100 else ""


def _battery(value: float | None) -> str:
    number = _finite(value)
    if number is None or number < 0:
        return ""
    volts = round(number, 1)
    return f"batt {volts:.1f}V" if volts < 100 else ""
