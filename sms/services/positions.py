"""The glider's position SMS (issue 20 §5): what one says, and the round of them the bridge
queues on its schedule (``sms.bridge.positions``) for the modem loop to send like any reply.

Each is an outgoing SMS of the vessel's log, pending, to one authorised number that receives
positions. Its ``delivery_key`` names the vessel, the number and the fix (``pos:<vessel>:
<number>:<fix time>``): the unique index lets one SMS per fix and number in, whatever a
restart or a retry does. Its ``parsed`` is ``[{"position": <the fix's time>, "round": <when the
round was queued>}]``: where a restarted bridge finds its schedule's place.
"""

from __future__ import annotations

import datetime as dt
import logging
from dataclasses import dataclass, field

from django.db import IntegrityError, transaction

from commands import catalog
from commands.errors import CatalogError
from commands.lifecycle import Status
from sms import selectors
from sms.models import Direction, SendStatus, SmsMessage
from sms.position_text import PositionReport, format_position
from sms.services._common import _save_checked
from vessels.models import Vessel

logger = logging.getLogger(__name__)

PARSED_KEY = "position"
ROUND_KEY = "round"


@dataclass(frozen=True)
class PositionRound:
    """What :func:`sms_position_queue` did."""

    text: str
    queued: list[SmsMessage] = field(default_factory=list)
    already: int = 0  # numbers that had been sent this fix before


@dataclass(frozen=True)
class LastRound:
    """The vessel's newest position SMS: when it was queued and the fix it carried."""

    sent_at: dt.datetime
    fix_at: dt.datetime | None


def position_key(vessel: Vessel, number: str, fix_at: dt.datetime) -> str:
    """The delivery key of the position SMS of the fix of ``fix_at`` to ``number``."""
    when = fix_at.astimezone(dt.UTC)
    return f"{selectors.POSITION_KEY_PREFIX}{vessel.pk}:{number}:{when:%Y%m%dT%H%M%SZ}"


def position_last_round(*, vessel: Vessel) -> LastRound | None:
    """Where the schedule stood when the bridge last sent a round (None: it never did)."""
    message = selectors.bridge_last_position_sms(vessel=vessel)
    if message is None:
        return None
    record = next((r for r in message.parsed or [] if isinstance(r, dict)), {})
    return LastRound(
        _time(record.get(ROUND_KEY)) or message.created_at, _time(record.get(PARSED_KEY))
    )


def _time(value: object) -> dt.datetime | None:
    try:
        when = dt.datetime.fromisoformat(value) if isinstance(value, str) else None
    except ValueError:
        return None
    return when if when is not None and when.tzinfo is not None else None


def position_state(*, vessel: Vessel, cc_silent_s: float | None = None) -> str:
    """The C&C's state as the bridge knows it: the navigation order in force (its status when
    not done yet), and how long the C&C has been silent when it has."""
    parts: list[str] = []
    navigation = selectors.navigation_current(vessel=vessel)
    if navigation is not None:
        try:
            order = catalog.to_text(navigation.kind, navigation.params)
        except (CatalogError, KeyError, TypeError, ValueError):
            order = navigation.kind
        status = "" if navigation.status == Status.DONE else f" {navigation.status}"
        parts.append(f"nav {order}{status}")
    if cc_silent_s is not None:
        parts.append(f"C&C silent {_age(cc_silent_s)}")
    return ", ".join(parts)


def _age(seconds: float) -> str:
    seconds = max(0, int(seconds))
    for unit, size, below in (("s", 1, 120), ("m", 60, 120 * 60), ("h", 3600, 48 * 3600)):
        if seconds < below:
            return f"{seconds // size}{unit}"
    return f"{seconds // 86400}d"


def position_report(*, vessel: Vessel, state: str = "") -> PositionReport | None:
    """The vessel's last fix as a position SMS says it; None when it has no fix."""
    fresh = selectors.bridge_vessel_last_fix(vessel=vessel)
    fix = fresh.last_fix if isinstance(fresh.last_fix, dict) else {}
    lat, lon = fix.get("lat"), fix.get("lon")
    if fresh.last_fix_at is None or not isinstance(lat, int | float):
        return None
    if not isinstance(lon, int | float):
        return None
    return PositionReport(
        time=fresh.last_fix_at,
        lat=lat,
        lon=lon,
        heading_deg=fix.get("heading_deg"),
        speed_mps=fix.get("speed_mps"),
        battery_v=fix.get("battery_v"),
        name=fresh.name,
        state=state,
    )


@transaction.atomic
def sms_position_queue(
    *, vessel: Vessel, report: PositionReport, now: dt.datetime
) -> PositionRound:
    """Queue the position SMS of ``report`` for every number that receives the vessel's
    positions (pending: the modem loop sends them); a number that had this fix already is
    counted, not sent it again."""
    text = format_position(report)
    queued: list[SmsMessage] = []
    already = 0
    for entry in selectors.bridge_position_recipients(vessel=vessel, now=now):
        message = SmsMessage(
            direction=Direction.OUT,
            vessel=vessel,
            number=entry.number,
            number_e164=entry.number,
            authorised_number=entry,
            authorised=True,
            text=text,
            parsed=[{PARSED_KEY: report.time.isoformat(), ROUND_KEY: now.isoformat()}],
            delivery_key=position_key(vessel, entry.number, report.time),
            status=SendStatus.PENDING,
        )
        try:
            with transaction.atomic():
                queued.append(_save_checked(message))
        except IntegrityError:
            already += 1
    return PositionRound(text, queued, already)
