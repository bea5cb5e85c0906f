"""The simulated Rover's AP_Mission: items as it keeps them, advancing through them, and the
MAVLink mission protocol (upload GCS → vehicle, download vehicle → GCS) that
``edge_client.sim.rover.RoverSim`` speaks. Split from rover.py, which runs the modes, motion,
start-up and streams; a mixin because both halves share the one vehicle's state.
"""

from __future__ import annotations

import os
from collections import deque
from dataclasses import dataclass
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

from edge_client.contract.catalog import MISSION_MAX_MAVLINK_ITEMS  # noqa: E402
from edge_client.contract.fence import FENCE_MAX_ITEMS  # noqa: E402

mavlink = mavutil.mavlink

MISSION, FENCE = mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE
UPLOAD_RETRY_S = 0.5
UPLOAD_GIVE_UP_S = 8.0
GLOBAL_FRAMES = {0, 3, 5, 6, 10, 11}  # MAV_FRAME_GLOBAL*, incl. the deprecated _INT variants
# pymavlink's own numbers (the simulator has it; the pure mission code uses the contract's).
NAV_WAYPOINT, NAV_LOITER_TIME = mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME
NAV_RTL, DO_JUMP = mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, mavlink.MAV_CMD_DO_JUMP
DO_CHANGE_SPEED = mavlink.MAV_CMD_DO_CHANGE_SPEED
NAV_COMMANDS = {NAV_WAYPOINT, NAV_LOITER_TIME, NAV_RTL}  # the ones this Rover drives to
LOCATION_COMMANDS = {NAV_WAYPOINT, NAV_LOITER_TIME}  # AP_Mission keeps their x, y, z
# AP_Mission on a 16 KiB storage board: the capacity the server's catalog assumes.
MAX_MISSION_ITEMS = MISSION_MAX_MAVLINK_ITEMS
FIRST_ITEM = 1  # AP_MISSION_FIRST_REAL_COMMAND: item 0 is home, never run
MAX_JUMPS_FOLLOWED = 64  # AP_Mission::get_next_cmd gives up after this many DO_JUMPs in a row
SPEED_MIN_MPS = 0.05  # AR_WPNAV_SPEED_MIN: DO_CHANGE_SPEED below this changes nothing


@dataclass
class Item:
    seq: int
    frame: int
    command: int
    current: int
    autocontinue: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int  # degE7
    y: int
    z: float


def stored(item: Item) -> Item:
    """The item as ArduPilot Rover keeps it and hands it back on a download.

    AP_Mission (``mavlink_int_to_mission_cmd`` / ``mission_cmd_to_mavlink_int``) keeps only
    some fields of each command, in small integers: NAV_WAYPOINT its hold in whole seconds
    (uint16 ``p1``; the acceptance radius is kept for Plane only), NAV_LOITER_TIME the same
    plus a direction (param3 -1 or 1) and cross-track flag (param4 0 or 1), DO_CHANGE_SPEED
    speed type and throttle as uint8 and the speed as a float, DO_JUMP target uint16 and
    repeat count int16, NAV_RETURN_TO_LAUNCH nothing. Commands without a position come back
    with zeros in MAV_FRAME_GLOBAL; every item with autocontinue 1. Commands this simulator
    does not know are kept as they came.
    """
    c = item.command
    if c not in NAV_COMMANDS | {DO_JUMP, DO_CHANGE_SPEED}:
        return item
    p = [0.0, 0.0, 0.0, 0.0]
    if c in LOCATION_COMMANDS:
        p[0] = float(int(max(0.0, item.param1)) & 0xFFFF)
    if c == NAV_LOITER_TIME:
        p[2] = -1.0 if item.param3 < 0 else 1.0
        p[3] = 1.0 if item.param4 > 0 else 0.0
    if c == DO_CHANGE_SPEED:
        p[:3] = [float(int(item.param1) & 0xFF), item.param2, float(int(item.param3) & 0xFF)]
    if c == DO_JUMP:
        times = int(item.param2)
        p[:2] = [float(int(item.param1) & 0xFFFF), float((times + 0x8000) % 0x10000 - 0x8000)]
    if c in LOCATION_COMMANDS:
        # Relative-altitude frames come back as MAV_FRAME_GLOBAL_RELATIVE_ALT, terrain ones as
        # MAV_FRAME_GLOBAL_TERRAIN_ALT, the rest as MAV_FRAME_GLOBAL; altitude in whole cm.
        frame = {3: 3, 6: 3, 10: 10, 11: 10}.get(item.frame, 0)
        x, y, z = item.x, item.y, round(item.z * 100) / 100
    else:
        frame, x, y, z = 0, 0, 0, 0.0
    return Item(item.seq, frame, c, 0, 1, *p, x, y, z)


@dataclass(frozen=True)
class Event:
    """Something the mission did, at ``t`` on the simulator's clock (its ``monotonic``)."""

    t: float
    kind: str  # "arrived", "reached" (MISSION_ITEM_REACHED sent), "speed", "complete"
    seq: int
    value: float = 0.0


class MissionProtocol:
    """AP_Mission for ``RoverSim``: advancing through the items (DO_JUMPs, DO commands, the next
    navigation item), setting the current one, and the upload and download protocol. RoverSim
    holds the state named here and provides ``_emit``, ``_peer``, ``_send_current``,
    ``statustext`` and ``mode_name``; its AUTO mode drives to the items."""

    mission: list[Item]
    max_items: int
    request_int: bool
    reject_mission: int | None
    upload: dict[str, Any] | None
    uploaded: dict[str, Any] | None
    current: int
    home: tuple[float, float]
    jumps: dict[int, int]
    events: deque[Event]
    speed: float
    cruise_speed: float
    complete: bool
    nav_loaded: bool
    arrived_at: float | None

    def _item_done(self, item: Item, now: float) -> None:
        # Rover's verify_command_callback: MISSION_ITEM_REACHED once an item is *done*.
        self._emit(None, "mission_item_reached", item.seq)
        self.events.append(Event(now, "reached", item.seq))

    def _advance(self, start: int, now: float) -> bool:
        """AP_Mission advance_current_nav_cmd: follow DO_JUMPs, run the DO commands met on the
        way (each verified at once), stop at the next navigation item; none left: complete."""
        index, followed = max(start, FIRST_ITEM), 0
        while index < len(self.mission):
            item = self.mission[index]
            if item.command == DO_JUMP:
                target, times = int(item.param1), int(item.param2)
                followed += 1
                if followed > MAX_JUMPS_FOLLOWED or not FIRST_ITEM <= target < len(self.mission):
                    break  # AP_Mission::get_next_cmd fails: the mission ends
                done = self.jumps.get(item.seq, 0)
                if times == -1 or done < times:
                    self.jumps[item.seq] = done + 1
                    index = target
                else:
                    index += 1
                continue
            if item.command in NAV_COMMANDS:
                self.current, self.nav_loaded, self.arrived_at = index, True, None
                if item.command == NAV_RTL:
                    self.speed = self.cruise_speed  # ModeRTL::_enter starts at RTL_SPEED/WP_SPEED
                return True
            if item.command == DO_CHANGE_SPEED and item.param2 >= SPEED_MIN_MPS:
                self.speed = item.param2
                self.events.append(Event(now, "speed", item.seq, item.param2))
                self.statustext(None, f"speed: {item.param2:.1f} m/s", 6)
            self._item_done(item, now)
            index += 1
        self.complete, self.nav_loaded = True, False
        self.events.append(Event(now, "complete", self.current))
        self.statustext(None, "Mission Complete", 5)
        return False

    def _on_mission_set_current(self, conn: Any, msg: Any, now: float) -> None:
        if 0 <= msg.seq < len(self.mission):
            self._set_current(msg.seq)

    def _set_current(self, seq: int) -> None:
        # AP_Mission::set_current_cmd; GCS_MAVLINK echoes the seq asked for in MISSION_CURRENT.
        self.current, self.nav_loaded, self.arrived_at, self.complete = seq, False, None, False
        self._send_current(seq)

    def load_mission(self, items: list[Item]) -> None:
        """A new mission, as an accepted upload leaves it (a test may load one directly): kept
        as AP_Mission keeps it (:func:`stored`), not started."""
        self.mission = [stored(i) for i in items]
        self.current, self.jumps, self.complete = 0, {}, False
        self.nav_loaded, self.arrived_at = False, None

    def _on_mission_clear_all(self, conn: Any, msg: Any, now: float) -> None:
        kind = getattr(msg, "mission_type", MISSION)
        if kind == FENCE:
            self.fence_store([])
        elif kind == MISSION:
            self.load_mission([])
        self._mission_ack(conn, mavlink.MAV_MISSION_ACCEPTED, kind)

    def _mission_ack(self, conn: Any, code: int, kind: int = 0) -> None:
        self._emit(conn, "mission_ack", *self._peer(conn), code, kind)

    # Upload: GCS → vehicle ---------------------------------------------------------------------

    def _on_mission_count(self, conn: Any, msg: Any, now: float) -> None:
        # The mission and the geofence (mission_type FENCE, edge_client.sim.fence) share the
        # protocol, as ArduPilot's MissionItemProtocol does; rally points are not kept.
        kind = getattr(msg, "mission_type", MISSION)
        if kind not in (MISSION, FENCE):
            self._mission_ack(conn, mavlink.MAV_MISSION_UNSUPPORTED, kind)
            return
        if msg.count > (self.max_items if kind == MISSION else FENCE_MAX_ITEMS):
            self._mission_ack(conn, mavlink.MAV_MISSION_NO_SPACE, kind)
            return
        if msg.count == 0:
            if kind == FENCE:
                self.fence_store([])
            else:
                self.load_mission([])
            self._mission_ack(conn, mavlink.MAV_MISSION_ACCEPTED, kind)
            return
        self.upload = {"conn": conn, "count": msg.count, "items": [], "started": now, "type": kind}
        self.uploaded = None
        self._request_next(now)

    def _request_next(self, now: float) -> None:
        up = self.upload
        assert up is not None
        up["asked_at"] = now
        seq = len(up["items"])
        name = "mission_request_int" if self.request_int else "mission_request"
        self._emit(up["conn"], name, *self._peer(up["conn"]), seq, up["type"])

    def _upload_timeouts(self, now: float) -> None:
        up = self.upload
        if up is None:
            return
        if now - up["started"] > UPLOAD_GIVE_UP_S:
            self.upload = None
            self._mission_ack(up["conn"], mavlink.MAV_MISSION_OPERATION_CANCELLED, up["type"])
        elif now - up["asked_at"] > UPLOAD_RETRY_S:
            self._request_next(now)

    def _on_mission_item_int(self, conn: Any, msg: Any, now: float) -> None:
        self._item_received(conn, msg, int(msg.x), int(msg.y), now)

    def _on_mission_item(self, conn: Any, msg: Any, now: float) -> None:
        if msg.current == 2:  # "guided mode" waypoint: a target for GUIDED only
            ok = self.mode_name == "GUIDED"
            if ok:
                self.target = (msg.x, msg.y)
            self._mission_ack(
                conn, mavlink.MAV_MISSION_ACCEPTED if ok else mavlink.MAV_MISSION_ERROR
            )
            return
        self._item_received(conn, msg, int(round(msg.x * 1e7)), int(round(msg.y * 1e7)), now)

    def _item_received(self, conn: Any, msg: Any, x: int, y: int, now: float) -> None:
        if msg.current == 2 and msg.get_type() == "MISSION_ITEM_INT":
            ok = self.mode_name == "GUIDED"
            if ok:
                self.target = (x / 1e7, y / 1e7)
            self._mission_ack(
                conn, mavlink.MAV_MISSION_ACCEPTED if ok else mavlink.MAV_MISSION_ERROR
            )
            return
        up = self.upload
        done = self.uploaded
        kind = getattr(msg, "mission_type", MISSION)
        if up is None and done and done["conn"] is conn and msg.seq == done["count"] - 1:
            # The last item again: our MISSION_ACK was lost. Say it again (PX4 does, PR #9547)
            # rather than leave the sender retrying into a cancelled upload.
            self._mission_ack(conn, done["code"], done["type"])
            return
        if up is None or up["conn"] is not conn or kind != up["type"]:
            return
        if msg.seq != len(up["items"]):
            self._request_next(now)  # a late duplicate or a skipped item: ask for the one we need
            return
        if msg.frame not in GLOBAL_FRAMES and msg.command in LOCATION_COMMANDS:
            self.upload = None
            self._mission_ack(conn, mavlink.MAV_MISSION_UNSUPPORTED_FRAME)
            return
        if msg.command in LOCATION_COMMANDS and not -90e7 <= x <= 90e7:
            self.upload = None
            self._mission_ack(conn, mavlink.MAV_MISSION_INVALID_PARAM5_X)
            return
        if msg.command in LOCATION_COMMANDS and not -180e7 <= y <= 180e7:
            self.upload = None
            self._mission_ack(conn, mavlink.MAV_MISSION_INVALID_PARAM6_Y)
            return
        up["items"].append(
            Item(
                msg.seq,
                msg.frame,
                msg.command,
                0,
                msg.autocontinue,
                msg.param1,
                msg.param2,
                msg.param3,
                msg.param4,
                x,
                y,
                msg.z,
            )
        )
        if len(up["items"]) < up["count"]:
            self._request_next(now)
            return
        self.upload = None
        if kind == FENCE:
            code = self.fence_store(up["items"])
        else:
            code = self.reject_mission
            code = mavlink.MAV_MISSION_ACCEPTED if code is None else code
            if code == mavlink.MAV_MISSION_ACCEPTED:
                self.load_mission(up["items"])
        self.uploaded = {"conn": conn, "count": up["count"], "code": code, "type": kind}
        self._mission_ack(conn, code, kind)

    # Download: vehicle → GCS -----------------------------------------------------------------

    def _mission_for_download(self) -> list[Item]:
        home = Item(
            0,
            0,
            NAV_WAYPOINT,
            0,
            1,
            0,
            0,
            0,
            0,
            int(self.home[0] * 1e7),
            int(self.home[1] * 1e7),
            0,
        )
        return [home, *self.mission[1:]]

    def _download(self, kind: int) -> list[Item]:
        if kind == FENCE:
            return self.fence_for_download()
        return self._mission_for_download() if kind == MISSION else []

    def _on_mission_request_list(self, conn: Any, msg: Any, now: float) -> None:
        kind = getattr(msg, "mission_type", MISSION)
        self._emit(conn, "mission_count", *self._peer(conn), len(self._download(kind)), kind)

    def _on_mission_request_int(self, conn: Any, msg: Any, now: float) -> None:
        self._send_item(conn, msg.seq, getattr(msg, "mission_type", MISSION), as_int=True)

    def _on_mission_request(self, conn: Any, msg: Any, now: float) -> None:
        self._send_item(conn, msg.seq, getattr(msg, "mission_type", MISSION), as_int=False)

    def _send_item(self, conn: Any, seq: int, kind: int, *, as_int: bool) -> None:
        items = self._download(kind)
        if not 0 <= seq < len(items):
            self._mission_ack(conn, mavlink.MAV_MISSION_INVALID_SEQUENCE, kind)
            return
        it = items[seq]
        current = 1 if seq == self.current and kind == MISSION else 0
        # MISSION_ITEM_INT carries degrees * 1e7 as integers; the old MISSION_ITEM, float degrees.
        name, x, y = (
            ("mission_item_int", it.x, it.y) if as_int else ("mission_item", it.x / 1e7, it.y / 1e7)
        )
        params = (it.param1, it.param2, it.param3, it.param4)
        self._emit(
            conn, name, *self._peer(conn), it.seq, it.frame, it.command, current, it.autocontinue,
            *params, x, y, it.z, kind,
        )  # fmt: skip
