"""What each alert rule kind watches, with hysteresis. Pure: no ORM, no I/O.

A rule's condition on one vessel is a small state machine with two states, *clear* and *active*
(an alert episode is open or acknowledged). Each observation (a fix, a vessel's silence, an
endurance estimate, a finished command) gives one of three verdicts:

- ``HOLDS``: the condition is met: open an episode if none is active;
- ``CLEARS``: the condition is well clear of its limit: resolve the active episode;
- ``KEEP``: no verdict: the value lies between the opening and the clearing limit, or there is
  no value (the reading is missing, no endurance estimate yet): stay as you are.

Hysteresis: the limit that opens and the limit that clears differ by a margin, so a value
hovering at the limit opens one episode, not one per fix.

The evaluator (alerts/evaluator.py) feeds observations in time order through :func:`step`;
tests feed it sequences (tests/alerts/test_rules.py: never more than one episode per crossing).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from enum import Enum
from typing import Any

from edge_client.contract.geo import EARTH_RADIUS_M


class Verdict(Enum):
    HOLDS = "holds"
    CLEARS = "clears"
    KEEP = "keep"  # between the open and the clear limits, or no data: stay as you are


HOLDS, CLEARS, KEEP = Verdict.HOLDS, Verdict.CLEARS, Verdict.KEEP

# Silent longer than this many of its own telemetry periods: overdue (the vessel list's own
# figure, vessels.models.OVERDUE_PERIODS, when the rule leaves its threshold empty).
DEFAULT_OVERDUE_PERIODS = 3.0
# A battery alert clears only this far above its threshold (volts): a 12 V pack's voltage
# moves by a few tenths with the motor's load, and a boat at the limit must not flap.
BATTERY_MARGIN_V = 0.2
# A reading alert clears only this far inside its limits, as a fraction of the range between
# them (2 % of 0-100 % humidity is 2 points); with one limit only, of that limit's magnitude.
READING_MARGIN_FRACTION = 0.02
# ... and never less than this (a limit of 0 with one side only has no magnitude to take 2 % of).
READING_MARGIN_MIN = 1e-6
# An endurance alert clears once the estimate is this many times the threshold (and at least
# ENDURANCE_MARGIN_H more): the estimate wobbles as hours roll over.
ENDURANCE_CLEAR_FACTOR = 1.25
ENDURANCE_MARGIN_H = 1.0
# A fence alert clears once the vessel is this far back on the allowed side (metres): a GPS
# fix wanders by several metres, and a boat sailing along the line must not flap.
FENCE_MARGIN_M = 20.0


def step(active: bool, verdict: Verdict) -> tuple[bool, str | None]:
    """One observation through the state machine: (active after it, "open"/"resolve"/None)."""
    if not active and verdict is HOLDS:
        return True, "open"
    if active and verdict is CLEARS:
        return False, "resolve"
    return active, None


def run(active: bool, verdicts: Iterable[Verdict]) -> tuple[bool, list[str]]:
    """A sequence of observations: the state after them and the transitions, in order."""
    transitions = []
    for verdict in verdicts:
        active, change = step(active, verdict)
        if change:
            transitions.append(change)
    return active, transitions


# Overdue ----------------------------------------------------------------------------------


def overdue_limit_s(period_s: float, threshold: float | None) -> float:
    """Seconds of silence after which a vessel reporting every ``period_s`` is overdue."""
    periods = threshold if threshold is not None and threshold > 0 else DEFAULT_OVERDUE_PERIODS
    return period_s * periods


def overdue(silent_s: float | None, limit_s: float) -> Verdict:
    """Overdue holds once silent longer than the limit, and clears when it reports again
    (silent no longer than the limit: a report since it went overdue). A vessel never seen is
    not overdue: there is nothing to be late for yet."""
    if silent_s is None:
        return KEEP
    return HOLDS if silent_s > limit_s else CLEARS


# Battery ----------------------------------------------------------------------------------


def battery(volts: float | None, threshold: float, clear_above: float | None = None) -> Verdict:
    """Holds below ``threshold``; clears above ``clear_above`` (default threshold +
    BATTERY_MARGIN_V, a rule's ``maximum`` when it gives one)."""
    if not is_number(volts):
        return KEEP
    clear = battery_clear_v(threshold, clear_above)
    if volts < threshold:
        return HOLDS
    return CLEARS if volts > clear else KEEP


def battery_clear_v(threshold: float, clear_above: float | None = None) -> float:
    """The voltage a battery alert clears above (:func:`battery`)."""
    return clear_above if clear_above is not None else threshold + BATTERY_MARGIN_V


# Reading ----------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Limits:
    """A reading's allowed range (either side may be open) and the clear margin."""

    low: float | None
    high: float | None

    @property
    def margin(self) -> float:
        if self.low is not None and self.high is not None and self.high > self.low:
            return max((self.high - self.low) * READING_MARGIN_FRACTION, READING_MARGIN_MIN)
        bound = self.low if self.low is not None else self.high
        return max(abs(bound or 0.0) * READING_MARGIN_FRACTION, READING_MARGIN_MIN)

    @property
    def usable(self) -> bool:
        return self.low is not None or self.high is not None


def reading_limits(
    rule_min: float | None,
    rule_max: float | None,
    channel_min: float | None,
    channel_max: float | None,
) -> Limits:
    """The rule's own limits; each one it leaves empty defaults to the SensorChannel's."""
    return Limits(
        low=rule_min if rule_min is not None else channel_min,
        high=rule_max if rule_max is not None else channel_max,
    )


def reading(value: Any, limits: Limits) -> Verdict:
    """Holds outside [low, high]; clears only ``margin`` inside both; no reading: KEEP."""
    if not is_number(value) or not limits.usable:
        return KEEP
    low, high, margin = limits.low, limits.high, limits.margin
    if (low is not None and value < low) or (high is not None and value > high):
        return HOLDS
    if (low is None or value >= low + margin) and (high is None or value <= high - margin):
        return CLEARS
    return KEEP


# Endurance --------------------------------------------------------------------------------


def endurance(hours: float | None, threshold: float) -> Verdict:
    """Holds when the estimate is below ``threshold`` hours; clears once it is well above it
    (math.inf, a battery not draining, clears); no estimate: KEEP."""
    if hours is None or (isinstance(hours, float) and math.isnan(hours)):
        return KEEP
    if hours < threshold:
        return HOLDS
    clear = max(threshold * ENDURANCE_CLEAR_FACTOR, threshold + ENDURANCE_MARGIN_H)
    return CLEARS if hours > clear else KEEP


# Fence ------------------------------------------------------------------------------------

# Bearings (degrees) of the points around a fix that must all be on the allowed side for a
# fence alert to clear: eight, so a narrow spit of forbidden water is not missed between them.
FENCE_PROBE_BEARINGS = (0, 45, 90, 135, 180, 225, 270, 315)


def fence(
    lat: float,
    lon: float,
    inclusion: bool,
    contains: Callable[[float, float], bool],
    *,
    need_clear: bool = True,
) -> Verdict:
    """Holds when the fix breaks the fence (outside an inclusion zone, inside an exclusion
    zone); clears when it and the points FENCE_MARGIN_M around it all keep it.

    ``contains(lat, lon)`` answers "is this point inside the fence's area": the distance from
    the boundary is judged by asking it about probe points, so any geometry (polygon, circle)
    gets the same margin without a distance-to-edge routine of its own.

    ``need_clear=False`` (no episode is active, so CLEARS and KEEP mean the same) skips the
    probes: a fix on the allowed side is then KEEP, at one ``contains`` instead of nine."""

    def allowed(la: float, lo: float) -> bool:
        return contains(la, lo) == inclusion

    if not allowed(lat, lon):
        return HOLDS
    if not need_clear:
        return KEEP
    if all(allowed(*offset(lat, lon, b, FENCE_MARGIN_M)) for b in FENCE_PROBE_BEARINGS):
        return CLEARS
    return KEEP


def offset(lat: float, lon: float, bearing_deg: float, distance_m: float) -> tuple[float, float]:
    """The point ``distance_m`` from (lat, lon) on ``bearing_deg`` (small distances: a local
    flat-Earth step is metres-accurate at tens of metres; longitude wraps at the antimeridian)."""
    b = math.radians(bearing_deg)
    dlat = math.degrees(distance_m * math.cos(b) / EARTH_RADIUS_M)
    cos_lat = max(math.cos(math.radians(lat)), 1e-9)
    dlon = math.degrees(distance_m * math.sin(b) / (EARTH_RADIUS_M * cos_lat))
    new_lat = max(-90.0, min(90.0, lat + dlat))
    new_lon = (lon + dlon + 180.0) % 360.0 - 180.0
    return new_lat, new_lon


# Command ----------------------------------------------------------------------------------

# Command statuses a command rule alerts on (edge_client/contract/status.py's names).
COMMAND_BAD_ENDS = frozenset({"failed", "expired"})


def command(status: str) -> Verdict:
    """A command that ended failed or expired opens an episode of its own (subject: its uid).
    It resolves when a later command of the same kind to the same vessel ends ``done``
    (alerts/evaluator.py): the vessel did what was asked after all."""
    return HOLDS if status in COMMAND_BAD_ENDS else KEEP


# Budget -----------------------------------------------------------------------------------

# The transports a budget rule watches, and what each one's budget counts a UTC day.
BUDGET_UNITS = {"sbd": "credits", "sms": "SMS segments", "http": "kB"}


def budget(spent: float, limit: float | None) -> Verdict:
    """Holds once today's spending on a link is over its daily budget; clears when it is not.

    Spending only grows within a UTC day, so the hysteresis is the day itself: an episode
    opened at the crossing stays open until the next UTC day starts from zero, or until the
    budget is raised above what was spent (or removed: no budget clears). One episode per
    crossing, never one per message."""
    if limit is None or not is_number(limit) or not is_number(spent):
        return CLEARS
    return HOLDS if spent > limit else CLEARS


def is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
