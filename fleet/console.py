"""The fleet map's overlays (issue 18 §2): each vessel's trail of recent positions, the
mission it is running and its battery endurance, read together for the whole fleet.

Polled far less often than the fleet itself (``FLEET_MAP_TRAIL_REFRESH_S``): between two
reads the page extends each trail with the last fixes the fleet poll brings anyway. Reads only:
a trail is the vessel's track over the last minutes, sketched from the track overview's
buckets (and from the fixes of minutes not yet rebuilt, as the track view does), and a vessel
with no fix in the window costs no query at all.
"""

from __future__ import annotations

import datetime as dt
import hashlib
from collections.abc import Iterable, Mapping
from typing import Any

from django.core.cache import cache

from alerts.selectors import endurance_entry, fleet_endurance_hours
from commands.models import Command
from edge_client.contract.status import UNFINISHED, Status
from telemetry.track import gap_seconds, sketch
from vessels.models import Vessel

# A trail is a sketch of the last minutes, not the track view: this many points at most.
TRAIL_MAX_POINTS = 300
TRAIL_MAX_MINUTES = 24 * 60
COORD_DECIMALS = 6  # ~0.1 m, as the track endpoint
MISSION_KIND = "mission"
# Endurance moves when an hour's battery mean is complete: read at most this often.
ENDURANCE_CACHE_S = 300


def _epoch(t: float) -> float | int:
    return int(t) if t == int(t) else round(t, 3)


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _fix_time(vessel: Vessel) -> dt.datetime | None:
    last = vessel.last_fix or {}
    try:
        return dt.datetime.fromisoformat(last["time"])
    except (KeyError, TypeError, ValueError):
        return None


def trail(vessel: Vessel, start: dt.datetime, end: dt.datetime) -> dict[str, Any]:
    """The vessel's positions in [start, end) as lines of [t, lat, lon] (t in Unix seconds),
    broken where it was silent longer than ``gap_s``. No query when its newest fix is older
    than ``start`` (Vessel.last_fix is the newest fix it ever sent)."""
    newest = _fix_time(vessel)
    if newest is None or newest < start:
        return {"gap_s": gap_seconds(vessel), "lines": []}
    result = sketch(vessel=vessel, start=start, end=end, max_points=TRAIL_MAX_POINTS)
    lines = [
        [[_epoch(t), round(lat, COORD_DECIMALS), round(lon, COORD_DECIMALS)] for t, lat, lon in s]
        for s in result.segments
    ]
    return {"gap_s": result.gap_s, "lines": lines}


def running_missions(vessel_ids: Iterable[int]) -> dict[int, Command]:
    """Per vessel, the mission it is running: its newest acknowledged ``mission`` command, else
    its newest one still on the way to it (queued or sent). One query."""
    chosen: dict[int, Command] = {}
    unfinished = [s.value for s in UNFINISHED]
    rows = (
        Command.objects.filter(
            vessel_id__in=list(vessel_ids), kind=MISSION_KIND, status__in=unfinished
        )
        .only("uid", "vessel_id", "params", "status", "created_at", "acknowledged_at")
        .order_by("vessel_id", "-created_at")
    )
    for command in rows:
        held = chosen.get(command.vessel_id)
        running = command.status == Status.ACKNOWLEDGED
        if held is None or (running and held.status != Status.ACKNOWLEDGED):
            chosen[command.vessel_id] = command
    return chosen


def mission_entry(command: Command) -> dict[str, Any]:
    """What the map draws of a mission: its route and how it ends; the waypoint the vessel is
    heading to comes with each fix (readings ``waypoint`` of ``waypoints``)."""
    params = command.params or {}
    items = [
        {"lat": round(i["lat"], COORD_DECIMALS), "lon": round(i["lon"], COORD_DECIMALS)}
        for i in params.get("items") or []
        if isinstance(i, dict) and _number(i.get("lat")) and _number(i.get("lon"))
    ]
    acknowledged = command.acknowledged_at
    return {
        "uid": str(command.uid),
        "status": command.status,
        "created_at": command.created_at.isoformat(),
        "acknowledged_at": acknowledged.isoformat() if acknowledged else None,
        "mission_id": params.get("mission_id"),
        "end": params.get("end") or ("loop" if params.get("loop") else "stop"),
        "items": items,
    }


def fleet_endurance(vessels: Iterable[Vessel], now: dt.datetime) -> dict[int, Mapping[str, Any]]:
    """Each vessel's battery endurance for its panel (alerts.selectors), read at most once per
    ENDURANCE_CACHE_S: it moves only when an hour's mean is complete, and the overlays are read
    by every open map."""
    ids = sorted(v.pk for v in vessels)
    key = "fleet-endurance:" + hashlib.sha256(",".join(map(str, ids)).encode()).hexdigest()
    entries = cache.get(key)
    if entries is None:
        hours = fleet_endurance_hours(ids, now=now)
        entries = {pk: endurance_entry(h) for pk, h in hours.items()}
        cache.set(key, entries, ENDURANCE_CACHE_S)
    return entries


def fleet_overlays(
    vessels: Iterable[Vessel], *, now: dt.datetime, minutes: int, trails: bool, missions: bool
) -> list[dict[str, Any]]:
    """Per vessel: its trail over the last ``minutes`` and its battery endurance (None without
    the right to see fixes), and its running mission (None when it runs none, or without the
    right to see commands)."""
    vessels = list(vessels)
    start = now - dt.timedelta(minutes=minutes)
    running = running_missions(v.pk for v in vessels) if missions and vessels else {}
    endurance = fleet_endurance(vessels, now) if trails and vessels else {}
    entries = []
    for vessel in vessels:
        mission = running.get(vessel.pk)
        entries.append(
            {
                "slug": vessel.slug,
                "trail": trail(vessel, start, now) if trails and minutes else None,
                "mission": mission_entry(mission) if mission else None,
                "endurance": endurance.get(vessel.pk),
            }
        )
    return entries
