"""The simulated Rover's geofence, as ArduPilot Rover keeps and enforces one.

- Storage (MissionItemProtocol_Fence, AC_PolyFence_loader): the upload and download run by
  :class:`edge_client.sim.mission.MissionProtocol` with mission_type FENCE; more than 84 items
  is MAV_MISSION_NO_SPACE; a frame that is not global is MAV_MISSION_UNSUPPORTED_FRAME, a
  command that is no fence item MAV_MISSION_UNSUPPORTED; a set ``validate_fence`` refuses
  (a polygon of fewer than 3 vertices or with the wrong count, a radius not above 0, a bad
  lat/lon) or one past 672 bytes of storage is MAV_MISSION_ERROR with the STATUSTEXT
  "Fence validation failed" / "Fence exceeds storage size". A circle's radius within 0.001 of
  a whole number is stored, and read back, as that whole number (write_fence's
  ``store_as_int``).
- Parameters (AC_Fence var_info, Rover's defaults): FENCE_ENABLE 0, FENCE_TYPE 6 (2: a circle
  of FENCE_RADIUS 300 m around home, 4: the uploaded polygons and circles), FENCE_ACTION 1,
  FENCE_MARGIN 2. PARAM_SET is answered with PARAM_VALUE; a name it does not know is ignored,
  as ArduPilot does. PARAM_REQUEST_READ is answered too.
- Enforcing (AC_Fence::check at 25 Hz, Rover/fence.cpp): while enabled, outside an inclusion
  fence, inside an exclusion one (edge_client.contract.fence: ArduPilot's intersection rule)
  or beyond FENCE_RADIUS of home is a breach. A new one counts in breach_count, sends
  FENCE_STATUS at once (record_breach) and the STATUSTEXT "Polygon fence breached" (the words
  Copter and Plane use, AC_Fence::print_fence_message; Rover 4.6 logs it only), and, armed,
  takes FENCE_ACTION: 1 (the default) RTL, or HOLD if RTL is refused; 2 HOLD; 3 SMART_RTL,
  RTL or HOLD; 4 SMART_RTL or HOLD; more than 100 m outside (AC_FENCE_GIVE_UP_DISTANCE) it
  just holds. FENCE_STATUS is streamed once a second while the fence is on.
"""

from __future__ import annotations

import os
import struct
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

from edge_client.contract import fence as shape  # noqa: E402 (pure)
from edge_client.contract.geo import distance_m  # noqa: E402 (pure)
from edge_client.contract.kinds import ROVER_MODES  # noqa: E402 (pure)
from edge_client.sim.mission import GLOBAL_FRAMES, Item  # noqa: E402

mavlink = mavutil.mavlink

POLYGONS = {
    mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION: True,
    mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION: False,
}
CIRCLES = {
    mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION: True,
    mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION: False,
}
TYPE_CIRCLE, TYPE_POLYGON = 2, 4  # AC_FENCE_TYPE_CIRCLE, AC_FENCE_TYPE_POLYGON
NAMES = {TYPE_CIRCLE: "Circle", TYPE_POLYGON: "Polygon"}  # AC_Fence::get_fence_names
DEFAULT_PARAMS: dict[str, float] = {
    "FENCE_ENABLE": 0,
    "FENCE_TYPE": TYPE_CIRCLE | TYPE_POLYGON,  # AC_FENCE_TYPE_DEFAULT for Rover
    "FENCE_ACTION": 1,  # AC_FENCE_ACTION_RTL_AND_LAND: Rover's "RTL or Hold"
    "FENCE_RADIUS": 300.0,
    "FENCE_MARGIN": 2.0,
}
INT_PARAMS = frozenset({"FENCE_ENABLE", "FENCE_TYPE", "FENCE_ACTION"})
# Rover's FENCE_ACTION (FailsafeAction) → the modes it tries in turn.
ACTION_MODES = {
    1: ("RTL", "HOLD"),
    2: ("HOLD",),
    3: ("SMART_RTL", "RTL", "HOLD"),
    4: ("SMART_RTL", "HOLD"),
}
GIVE_UP_M = 100.0  # AC_FENCE_GIVE_UP_DISTANCE: farther out, Rover only holds
CHECK_S = 0.04  # Rover::fence_run_checks, 25 Hz


def _float32(value: float) -> float:
    return struct.unpack("<f", struct.pack("<f", value))[0]


class FenceSim:
    """AC_Fence for ``RoverSim``, which provides ``_emit``, ``_peer``, ``statustext``,
    ``_set_mode``, ``_due``, ``boot_ms``, the position and ``home``, and ``armed``."""

    def _fence_init(self) -> None:
        self.fence: list[Item] = []  # as AC_PolyFence_loader keeps it
        self.params: dict[str, float] = dict(DEFAULT_PARAMS)
        self.fence_breaches = 0  # AC_Fence::_breached_fences (TYPE_* bits)
        self.fence_breach_count = 0
        self.fence_breach_time_ms = 0
        self.fence_actions: list[str] = []  # modes taken on a breach, for tests
        self._fence_checked = -1e9

    # -- storage ---------------------------------------------------------------------------

    def fence_store(self, items: list[Item]) -> int:
        """An accepted upload's items, checked as ArduPilot does; the MAV_MISSION_RESULT."""
        for item in items:
            if item.frame not in GLOBAL_FRAMES:
                return mavlink.MAV_MISSION_UNSUPPORTED_FRAME
            if item.command not in POLYGONS and item.command not in CIRCLES:
                return mavlink.MAV_MISSION_UNSUPPORTED
        shapes = self._shapes(items)
        if shapes is None:
            self.statustext(None, "Fence validation failed", 4)
            return mavlink.MAV_MISSION_ERROR
        if shape.storage_bytes(shapes) > shape.FENCE_STORAGE_BYTES:
            self.statustext(None, "Fence exceeds storage size", 4)
            return mavlink.MAV_MISSION_ERROR
        self.fence = [self._kept(i, item) for i, item in enumerate(items)]
        return mavlink.MAV_MISSION_ACCEPTED

    @staticmethod
    def _kept(seq: int, item: Item) -> Item:
        param1 = item.param1
        if item.command in CIRCLES:
            whole = float(int(param1))
            param1 = whole if param1 - whole < 0.001 else _float32(param1)  # store_as_int
        else:
            param1 = float(int(param1) & 0xFF)  # the vertex count is one byte
        return Item(seq, mavlink.MAV_FRAME_GLOBAL, item.command, 0, 0, param1, 0, 0, 0,
                    item.x, item.y, 0.0)  # fmt: skip

    @staticmethod
    def _shapes(items: list[Item]) -> list[dict[str, Any]] | None:
        """The fences items describe (the wire shape), or None where validate_fence fails."""
        fences, i = [], 0
        while i < len(items):
            item = items[i]
            if not (-90e7 <= item.x <= 90e7 and -180e7 <= item.y <= 180e7):
                return None  # "Bad lat or lon"
            if item.command in CIRCLES:
                if not item.param1 > 0:
                    return None  # "Non-positive circle radius"
                circle = {"lat": item.x / 1e7, "lon": item.y / 1e7, "radius_m": item.param1}
                fences.append({"inclusion": CIRCLES[item.command], "circle": circle})
                i += 1
                continue
            count = int(item.param1)
            group = items[i : i + count]
            if count < 3 or len(group) < count:
                return None  # "Invalid vertex count", "Incorrect item count"
            if any((g.command, g.param1) != (item.command, item.param1) for g in group):
                return None  # "Received incorrect vertex type" / "Unexpected vertex count"
            polygon = [[g.x / 1e7, g.y / 1e7] for g in group]
            fences.append({"inclusion": POLYGONS[item.command], "polygon": polygon})
            i += count
        return fences

    def fence_for_download(self) -> list[Item]:
        return list(self.fence)

    def fence_shapes(self) -> list[dict[str, Any]]:
        """The stored fences in the wire shape (edge_client.contract.fence)."""
        return self._shapes(self.fence) or []

    # -- parameters -------------------------------------------------------------------------

    def _param_value(self, conn: Any, name: str) -> None:
        value = self.params[name]
        kind = mavlink.MAV_PARAM_TYPE_INT8 if name in INT_PARAMS else mavlink.MAV_PARAM_TYPE_REAL32
        index = list(self.params).index(name)
        self._emit(conn, "param_value", name.encode(), float(value), kind, len(self.params), index)

    @staticmethod
    def _param_name(raw: Any) -> str:
        return (raw if isinstance(raw, str) else raw.decode("ascii", "replace")).rstrip("\x00")

    def _on_param_set(self, conn: Any, msg: Any, now: float) -> None:
        name = self._param_name(msg.param_id)
        if name not in self.params:
            return  # ArduPilot ignores a parameter it does not have
        value = msg.param_value
        self.params[name] = int(round(value)) if name in INT_PARAMS else float(value)
        if name == "FENCE_ENABLE" and not self.params[name]:
            self.fence_breaches = 0  # AC_Fence::enable(false) clears the breaches
        self._param_value(conn, name)

    def _on_param_request_read(self, conn: Any, msg: Any, now: float) -> None:
        name = self._param_name(msg.param_id)
        if not name and 0 <= msg.param_index < len(self.params):
            name = list(self.params)[msg.param_index]
        if name in self.params:
            self._param_value(conn, name)

    # -- enforcing --------------------------------------------------------------------------

    def _fence_status(self) -> None:
        kind = mavlink.FENCE_BREACH_BOUNDARY if self.fence_breaches else mavlink.FENCE_BREACH_NONE
        self._emit(None, "fence_status", 1 if self.fence_breaches else 0,
                   self.fence_breach_count, kind, self.fence_breach_time_ms)  # fmt: skip

    def _fence_check(self, now: float) -> None:
        """AC_Fence::check and Rover::fence_check, at 25 Hz; FENCE_STATUS once a second."""
        if now - self._fence_checked < CHECK_S:
            return
        self._fence_checked = now
        on = bool(self.params["FENCE_ENABLE"])
        types = int(self.params["FENCE_TYPE"]) if on else 0
        fences = self.fence_shapes() if types & TYPE_POLYGON else []
        breaches = 0
        if types & TYPE_CIRCLE:
            if distance_m(*self.home, self.lat, self.lon) >= self.params["FENCE_RADIUS"]:
                breaches |= TYPE_CIRCLE
        if fences and shape.breached(fences, self.lat, self.lon):
            breaches |= TYPE_POLYGON
        new = breaches & ~self.fence_breaches
        if new and not self.fence_breaches:
            self.fence_breach_time_ms = self.boot_ms()
        self.fence_breach_count += bin(new).count("1")
        changed = breaches != self.fence_breaches
        self.fence_breaches = breaches
        if new:
            names = " and ".join(NAMES[bit] for bit in (TYPE_CIRCLE, TYPE_POLYGON) if new & bit)
            self.statustext(None, f"{names} fence{'s' if new == 6 else ''} breached", 5)
            if self.armed:
                self._fence_action(new, fences, now)
        if changed or (on and self._due(mavlink.MAVLINK_MSG_ID_FENCE_STATUS, now)):
            self._fence_status()

    def _fence_action(self, new: int, fences: list[dict[str, Any]], now: float) -> None:
        action = int(self.params["FENCE_ACTION"])
        if action not in ACTION_MODES:
            return  # 0: report only
        out = 0.0
        if new & TYPE_POLYGON:
            broken = [f for f in fences if shape.contains(f, self.lat, self.lon) != f["inclusion"]]
            out = max(shape.boundary_distance_m(f, self.lat, self.lon) for f in broken)
        if new & TYPE_CIRCLE:
            home = distance_m(*self.home, self.lat, self.lon)
            out = max(out, home - self.params["FENCE_RADIUS"])
        modes = ("HOLD",) if out > GIVE_UP_M else ACTION_MODES[action]
        for mode in modes:
            if self._set_mode(None, ROVER_MODES[mode], now) == mavlink.MAV_RESULT_ACCEPTED:
                self.fence_actions.append(mode)
                return
