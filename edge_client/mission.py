"""The MAVLink mission protocol as a pure state machine (no I/O, no pymavlink).

References:
- mavlink.io/en/services/mission.html — upload: MISSION_COUNT → MISSION_REQUEST_INT(seq) /
  MISSION_ITEM_INT(seq) ... → MISSION_ACK; download: MISSION_REQUEST_LIST → MISSION_COUNT →
  MISSION_REQUEST_INT / MISSION_ITEM_INT ... → MISSION_ACK. Timeouts 1500 ms (exchange) and
  250 ms (per item when we request), at most 5 retries.
- docs/missions.md, 'The MAVLink mission protocol' — ArduPilot specifics: item 0 is home
  (prepend on upload, drop on download); Rover asks for items with the older MISSION_REQUEST,
  which we answer with MISSION_ITEM_INT just the same.

The link layer (:mod:`edge_client.mavlink_link`) feeds received messages as ``(type, fields)``
and sends what the machine returns as :class:`Out` values; tests drive the machines directly
with lost, repeated and out-of-order messages.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from edge_client.contract import mavcmd
from edge_client.contract.catalog import HOLD_MAX_S
from edge_client.contract.mavcmd import MavCmd

# The MAV_CMD numbers are the contract's (the server reads mission files with the same ones);
# common.xml MAV_FRAME / SPEED_TYPE / MAV_MISSION_RESULT values follow.
MAV_CMD_NAV_WAYPOINT = MavCmd.NAV_WAYPOINT
MAV_CMD_NAV_LOITER_TIME = MavCmd.NAV_LOITER_TIME
MAV_CMD_NAV_RETURN_TO_LAUNCH = MavCmd.NAV_RETURN_TO_LAUNCH
MAV_CMD_DO_JUMP = MavCmd.DO_JUMP
MAV_CMD_DO_CHANGE_SPEED = MavCmd.DO_CHANGE_SPEED
MAV_FRAME_GLOBAL = 0
MAV_FRAME_GLOBAL_RELATIVE_ALT = 3
SPEED_TYPE_GROUNDSPEED = 1
MAV_MISSION_TYPE_MISSION = 0
MAV_MISSION_TYPE_FENCE = 1  # the same protocol carries the geofence (edge_client.fence_upload)
MAV_MISSION_ACCEPTED = 0
MAV_MISSION_OPERATION_CANCELLED = 15

EXCHANGE_TIMEOUT_S = 1.5  # mission protocol default timeout
ITEM_TIMEOUT_S = 0.25  # per-item timeout when we are the side requesting items
MAX_RETRIES = 5
# ArduPilot DO_JUMP: a repeat count of -1 repeats forever (used for looping missions).
JUMP_FOREVER = -1
# Item 1 is the first real item: ArduPilot keeps home as item 0 (docs/missions.md).
FIRST_ITEM = 1
# ArduPilot keeps a waypoint's hold time in whole seconds (AP_Mission stores NAV_WAYPOINT
# param1 in the 16-bit ``p1``), and Rover reads it as signed: ``(int16_t)cmd.p1 < 0 ? 0``
# (Rover/mode_auto.cpp ``do_nav_wp``). A longer hold would silently become no hold at all.
ROVER_MAX_HOLD_S = int(HOLD_MAX_S)  # the contract's, which the server checks too


def result_name(code: int | None) -> str:
    if code is None:
        return "no MISSION_ACK"
    return mavcmd.name("MAV_MISSION_RESULT", code) or f"MAV_MISSION_RESULT {code}"


@dataclass(frozen=True)
class MissionItem:
    """One MISSION_ITEM_INT: lat/lon (``x``/``y``) in degrees × 1e7."""

    seq: int
    command: int
    x: int
    y: int
    z: float = 0.0
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    frame: int = MAV_FRAME_GLOBAL_RELATIVE_ALT
    current: int = 0
    autocontinue: int = 1

    def same_route(self, other: MissionItem) -> bool:
        """Equal as a mission (ignores ``current``, which the autopilot sets itself)."""
        keys = ("seq", "command", "x", "y", "frame", "autocontinue")
        params = ("param1", "param2", "param3", "param4", "z")
        return all(getattr(self, k) == getattr(other, k) for k in keys) and all(
            math.isclose(getattr(self, k), getattr(other, k), abs_tol=1e-4) for k in params
        )


def deg_to_e7(value: float) -> int:
    return int(round(value * 1e7))


class MissionError(ValueError):
    """Mission items the autopilot cannot take as they are."""


def hold_seconds(hold_s: float) -> int:
    """A hold time as ArduPilot keeps it: whole seconds, rounded up so no hold is lost."""
    seconds = math.ceil(hold_s)
    if seconds > ROVER_MAX_HOLD_S:
        raise MissionError(
            f"hold {hold_s:g} s is longer than ArduPilot Rover can hold at a waypoint "
            f"({ROVER_MAX_HOLD_S} s)"
        )
    return max(0, seconds)


def build_mission(
    home: tuple[float, float], items: list[dict[str, Any]], *, end: str = "stop"
) -> list[MissionItem]:
    """Mission items for ArduPilot, in this order (``commands.catalog.mission_mavlink_item_count``
    counts the same, and ``tests/edge_client/test_catalog_contract.py`` holds the two together):

    - item 0: home (NAV_WAYPOINT, MAV_FRAME_GLOBAL); ArduPilot keeps its own home there.
    - per mission item, when it has a ``speed_mps``: DO_CHANGE_SPEED *before* its waypoint, so
      the boat drives the leg to that waypoint, and everything after, at that speed (param1
      SPEED_TYPE_GROUNDSPEED, param2 m/s, param3 throttle 0 = unchanged by Rover). ArduPilot
      runs a DO command as soon as the navigation command before it is done.
    - per mission item: NAV_WAYPOINT, param1 = hold in whole seconds (:func:`hold_seconds`),
      param2 = acceptance radius in metres (0 = the autopilot's WP_RADIUS; common.xml).
      ArduPilot Rover keeps no per-waypoint radius (AP_Mission stores it for Plane only): it
      uses WP_RADIUS and reads param2 back as 0.
    - ``end == "loop"``: DO_JUMP to item 1 repeating forever (param1 target, param2 -1);
      ``end == "return_home"``: NAV_RETURN_TO_LAUNCH; ``end == "stop"``: nothing.

    Commands without a position carry zeros and MAV_FRAME_GLOBAL, which is how ArduPilot
    hands them back on a download (AP_Mission ``mission_cmd_to_mavlink_int``).
    Raises :class:`MissionError` for a hold longer than Rover can keep.
    """
    mission = [
        MissionItem(
            seq=0,
            command=MAV_CMD_NAV_WAYPOINT,
            x=deg_to_e7(home[0]),
            y=deg_to_e7(home[1]),
            frame=MAV_FRAME_GLOBAL,
        )
    ]

    def add(command: int, **fields: Any) -> None:
        fields.setdefault("frame", MAV_FRAME_GLOBAL)
        fields.setdefault("x", 0)
        fields.setdefault("y", 0)
        mission.append(MissionItem(seq=len(mission), command=command, **fields))

    for i, item in enumerate(items):
        if item.get("speed_mps") is not None:
            add(
                MAV_CMD_DO_CHANGE_SPEED,
                param1=float(SPEED_TYPE_GROUNDSPEED),
                param2=float(item["speed_mps"]),
            )
        try:
            hold = hold_seconds(float(item.get("hold_s") or 0.0))
        except MissionError as exc:
            raise MissionError(f"item {i}: {exc}") from None
        add(
            MAV_CMD_NAV_WAYPOINT,
            x=deg_to_e7(float(item["lat"])),
            y=deg_to_e7(float(item["lon"])),
            param1=float(hold),
            param2=float(item.get("radius_m") or 0.0),
            frame=MAV_FRAME_GLOBAL_RELATIVE_ALT,
        )
    if end == "loop":
        add(MAV_CMD_DO_JUMP, param1=float(FIRST_ITEM), param2=float(JUMP_FOREVER))
    elif end == "return_home":
        add(MAV_CMD_NAV_RETURN_TO_LAUNCH)
    elif end != "stop":
        raise MissionError(f"unknown mission end {end!r}")
    return mission


@dataclass(frozen=True)
class WaypointNumbers:
    """The operator's waypoint numbers (1 … ``count``) of a mission's MAVLink items.

    The autopilot counts MAVLink items (home at 0, a DO_CHANGE_SPEED before some waypoints, a
    final RTL or DO_JUMP: :func:`build_mission`); the operator counts waypoints. A
    DO_CHANGE_SPEED counts as the waypoint it leads to (the boat is on the leg to it); home,
    RTL and DO_JUMP are no waypoint.
    """

    by_seq: dict[int, int]
    count: int

    @classmethod
    def of(cls, items: list[MissionItem]) -> WaypointNumbers:
        by_seq: dict[int, int] = {}
        count, leading = 0, []
        for item in items[FIRST_ITEM:]:
            if item.command == MAV_CMD_NAV_WAYPOINT:
                count += 1
                by_seq.update(dict.fromkeys([*leading, item.seq], count))
                leading = []
            elif item.command == MAV_CMD_DO_CHANGE_SPEED:
                leading.append(item.seq)
        return cls(by_seq, count)

    def number(self, seq: int | None) -> int | None:
        return None if seq is None else self.by_seq.get(seq)

    def describe(self, seq: int | None) -> str:
        """ "waypoint 3 of 5" for an item of waypoint 3; "item 7" for one that is none."""
        number = self.number(seq)
        return f"item {seq}" if number is None else f"waypoint {number} of {self.count}"


@dataclass(frozen=True)
class Out:
    """A message to send: ``type`` is the MAVLink message name, ``fields`` its fields."""

    type: str
    fields: dict[str, Any] = field(default_factory=dict)


def item_out(item: MissionItem) -> Out:
    return Out(
        "MISSION_ITEM_INT",
        {
            "seq": item.seq,
            "frame": item.frame,
            "command": item.command,
            "current": item.current,
            "autocontinue": item.autocontinue,
            "param1": item.param1,
            "param2": item.param2,
            "param3": item.param3,
            "param4": item.param4,
            "x": item.x,
            "y": item.y,
            "z": item.z,
        },
    )


def item_from_fields(msg_type: str, f: dict[str, Any]) -> MissionItem:
    """MISSION_ITEM_INT (or the deprecated float MISSION_ITEM) → MissionItem."""
    x, y = f["x"], f["y"]
    if msg_type == "MISSION_ITEM":
        x, y = deg_to_e7(x), deg_to_e7(y)
    return MissionItem(
        seq=f["seq"],
        command=f["command"],
        x=int(x),
        y=int(y),
        z=float(f["z"]),
        param1=float(f["param1"]),
        param2=float(f["param2"]),
        param3=float(f["param3"]),
        param4=float(f["param4"]),
        frame=f["frame"],
        current=f["current"],
        autocontinue=f["autocontinue"],
    )


def _is_ours(f: dict[str, Any], mission_type: int) -> bool:
    """Whether a message belongs to an exchange of ``mission_type`` (MAVLink 1 has no field:
    a mission's)."""
    return f.get("mission_type", MAV_MISSION_TYPE_MISSION) == mission_type


class MissionUpload:
    """Sender side of an upload.

    1. ``start()`` → MISSION_COUNT.
    2. Each MISSION_REQUEST_INT or MISSION_REQUEST (seq) → that MISSION_ITEM_INT. A repeated
       request (our item was lost) is answered again; a request resets the retry count.
    3. MISSION_ACK ends it: MAV_MISSION_ACCEPTED once every item was requested is success;
       any other result is a failure carrying the code. An ACCEPTED that arrives before the last
       item was asked for is stale (an earlier exchange's, or duplicated) and ignored.
    4. ``poll(now)`` past the deadline re-sends the last message; after ``MAX_RETRIES`` it gives
       up, telling the autopilot with MISSION_ACK(MAV_MISSION_OPERATION_CANCELLED).
    """

    def __init__(
        self,
        items: list[MissionItem],
        *,
        timeout_s: float = EXCHANGE_TIMEOUT_S,
        mission_type: int = MAV_MISSION_TYPE_MISSION,
    ) -> None:
        self.items = items
        self.mission_type = mission_type
        self.timeout_s = timeout_s
        self.done = False
        self.ok = False
        self.result: int | None = None
        self.error = ""
        self.retries = 0
        self.deadline = 0.0
        self._last: list[Out] = []
        self._requested: set[int] = set()

    def start(self, now: float) -> list[Out]:
        self._last = [Out("MISSION_COUNT", {"count": len(self.items)})]
        self.deadline = now + self.timeout_s
        return self._last

    def handle(self, msg_type: str, f: dict[str, Any], now: float) -> list[Out]:
        if self.done or not _is_ours(f, self.mission_type):
            return []
        if msg_type in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            seq = f["seq"]
            if not 0 <= seq < len(self.items):
                return []  # not ours to answer; the autopilot will time out or ack an error
            self._requested.add(seq)
            self.retries = 0
            self._last = [item_out(self.items[seq])]
            self.deadline = now + self.timeout_s
            return self._last
        if msg_type == "MISSION_ACK":
            code = f["type"]
            if code == MAV_MISSION_ACCEPTED:
                if len(self._requested) < len(self.items):
                    return []
                self._finish(True, code, "")
            else:
                self._finish(False, code, f"autopilot rejected the mission: {result_name(code)}")
        return []

    def poll(self, now: float) -> list[Out]:
        if self.done or now < self.deadline:
            return []
        self.retries += 1
        if self.retries > MAX_RETRIES:
            self._finish(False, None, f"no answer from the autopilot after {MAX_RETRIES} retries")
            return [Out("MISSION_ACK", {"type": MAV_MISSION_OPERATION_CANCELLED})]
        self.deadline = now + self.timeout_s
        return self._last

    def _finish(self, ok: bool, code: int | None, error: str) -> None:
        self.done, self.ok, self.result, self.error = True, ok, code, error


class MissionDownload:
    """Requester side of a download (to read a mission back).

    MISSION_REQUEST_LIST → MISSION_COUNT; then MISSION_REQUEST_INT for each seq in turn, each
    re-sent after ``ITEM_TIMEOUT_S`` up to ``MAX_RETRIES`` times; MISSION_ACK(ACCEPTED) at the
    end. Items that are not the one asked for (late duplicates) are ignored.
    """

    def __init__(self, *, mission_type: int = MAV_MISSION_TYPE_MISSION) -> None:
        self.mission_type = mission_type
        self.done = False
        self.ok = False
        self.error = ""
        self.items: list[MissionItem] = []
        self.count: int | None = None
        self.retries = 0
        self.deadline = 0.0
        self._last: list[Out] = []

    def start(self, now: float) -> list[Out]:
        return self._send([Out("MISSION_REQUEST_LIST")], now, EXCHANGE_TIMEOUT_S)

    def handle(self, msg_type: str, f: dict[str, Any], now: float) -> list[Out]:
        if self.done or not _is_ours(f, self.mission_type):
            return []
        if msg_type == "MISSION_COUNT" and self.count is None:
            self.count = f["count"]
            return self._next(now)
        if msg_type in ("MISSION_ITEM_INT", "MISSION_ITEM") and self.count is not None:
            if f["seq"] != len(self.items):
                return []
            self.items.append(item_from_fields(msg_type, f))
            self.retries = 0
            return self._next(now)
        return []

    def poll(self, now: float) -> list[Out]:
        if self.done or now < self.deadline:
            return []
        self.retries += 1
        if self.retries > MAX_RETRIES:
            self.done, self.error = True, f"download stalled after {MAX_RETRIES} retries"
            return []
        timeout = EXCHANGE_TIMEOUT_S if self.count is None else ITEM_TIMEOUT_S
        return self._send(self._last, now, timeout)

    def _next(self, now: float) -> list[Out]:
        assert self.count is not None
        if len(self.items) == self.count:
            self.done = self.ok = True
            return [Out("MISSION_ACK", {"type": MAV_MISSION_ACCEPTED})]
        return self._send(
            [Out("MISSION_REQUEST_INT", {"seq": len(self.items)})], now, ITEM_TIMEOUT_S
        )

    def _send(self, out: list[Out], now: float, timeout: float) -> list[Out]:
        self._last = out
        self.deadline = now + timeout
        return out
