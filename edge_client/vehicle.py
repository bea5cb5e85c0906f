"""Vehicle state kept from MAVLink messages, one handler per message type.

As in the thesis' Mavlink manager (seed §4.3), each message type the client cares about has a
handler registered with the link; adding a sensor means registering one more handler (or
naming a ``[readings.*]`` source in the config). Handlers run on the link's reader thread and
only assign attributes, so readers on other threads see whole values (plain attribute writes
are atomic under the GIL); :meth:`VehicleState.fix` copies what it needs at once.

Message references (common.xml / ardupilotmega.xml): HEARTBEAT (base_mode bit
MAV_MODE_FLAG_SAFETY_ARMED = 128, custom_mode = Rover mode number), GLOBAL_POSITION_INT
(lat/lon degE7, vx/vy cm/s, hdg cdeg, 65535 = unknown), SYS_STATUS (voltage_battery mV,
65535 = unknown), MISSION_CURRENT, MISSION_ITEM_REACHED, HOME_POSITION, SYSTEM_TIME,
STATUSTEXT (pre-arm failure reasons).
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from edge_client.catalog import INITIALISING, ROVER_MODES
from edge_client.config import ReadingSource
from edge_client.geo import distance_m

log = logging.getLogger(__name__)

# HEARTBEAT custom_mode → name: the modes of the catalog plus the one seen while booting.
MODE_NAMES = {number: name for name, number in ROVER_MODES.items()} | {INITIALISING: "INITIALISING"}

MAV_MODE_FLAG_SAFETY_ARMED = 128
MAV_AUTOPILOT_INVALID = 8  # HEARTBEATs from GCSs and companions carry this; ignore them
UINT16_UNKNOWN = 65535
# Before this the Pi's clock has not been set (no RTC on a Pi Zero): trust the autopilot's.
CLOCK_SANE_AFTER = datetime(2024, 1, 1, tzinfo=UTC).timestamp()


@dataclass
class VehicleState:
    silent_after_s: float = 5.0
    system: int | None = None  # the autopilot's MAVLink system id, from its HEARTBEAT
    component: int = 1
    lat: float | None = None
    lon: float | None = None
    heading_deg: float | None = None
    speed_mps: float | None = None
    custom_mode: int | None = None
    armed: bool = False
    battery_v: float | None = None
    mission_seq: int | None = None
    last_reached: int | None = None
    home: tuple[float, float] | None = None
    time_boot_ms: int | None = None
    gps_clock_offset_s: float | None = None  # autopilot UTC (SYSTEM_TIME) minus our clock
    readings: dict[str, float] = field(default_factory=dict)
    statustext: deque[str] = field(default_factory=lambda: deque(maxlen=20))
    last_heartbeat: float | None = None  # time.monotonic()
    position_at: float | None = None  # time.monotonic() of the last GLOBAL_POSITION_INT fix
    was_silent: bool = False
    reconnects: int = 0
    reboots: int = 0
    # Called when the autopilot appears, comes back after silence or reboots (re-request streams).
    on_link_up: Callable[[], None] | None = None

    @property
    def mode(self) -> str | None:
        if self.custom_mode is None:
            return None
        return MODE_NAMES.get(self.custom_mode, str(self.custom_mode))

    def autopilot_ok(self, now: float | None = None) -> bool:
        now = time.monotonic() if now is None else now
        return self.last_heartbeat is not None and now - self.last_heartbeat < self.silent_after_s

    def check_silence(self, now: float) -> None:
        if self.last_heartbeat is not None and not self.was_silent and not self.autopilot_ok(now):
            self.was_silent = True
            log.warning("autopilot silent: no HEARTBEAT for %.1f s", now - self.last_heartbeat)

    def distance_to(self, lat: float, lon: float) -> float | None:
        if self.lat is None or self.lon is None:
            return None
        return distance_m(self.lat, self.lon, lat, lon)

    # -- handlers, one per message type ------------------------------------------------------

    def on_heartbeat(self, msg: Any) -> None:
        if msg.autopilot == MAV_AUTOPILOT_INVALID:
            return
        if self.system is not None and msg.get_srcSystem() != self.system:
            return
        now = time.monotonic()
        first = self.system is None
        self.system, self.component = msg.get_srcSystem(), msg.get_srcComponent()
        self.custom_mode = msg.custom_mode
        self.armed = bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
        came_back = self.was_silent
        self.last_heartbeat = now
        self.was_silent = False
        if first:
            log.info("autopilot found: system %d, mode %s", self.system, self.mode)
        elif came_back:
            self.reconnects += 1
            log.warning("autopilot back after silence (mode %s)", self.mode)
        if (first or came_back) and self.on_link_up:
            self.on_link_up()

    def on_global_position_int(self, msg: Any) -> None:
        if self.system is not None and msg.get_srcSystem() != self.system:
            return
        if self.time_boot_ms is not None and msg.time_boot_ms + 10_000 < self.time_boot_ms:
            # Boot time went backwards: the autopilot restarted and forgot our stream requests.
            self.reboots += 1
            log.warning("autopilot rebooted (time since boot went back)")
            if self.on_link_up:
                self.on_link_up()
        self.time_boot_ms = msg.time_boot_ms
        if msg.lat == 0 and msg.lon == 0:
            return  # no position yet (ArduPilot sends zeros before its first GPS fix)
        self.lat, self.lon = msg.lat / 1e7, msg.lon / 1e7
        self.position_at = time.monotonic()
        if msg.hdg != UINT16_UNKNOWN:
            self.heading_deg = msg.hdg / 100.0
        self.speed_mps = math.hypot(msg.vx, msg.vy) / 100.0

    def on_sys_status(self, msg: Any) -> None:
        if msg.voltage_battery != UINT16_UNKNOWN:
            self.battery_v = msg.voltage_battery / 1000.0

    def on_mission_current(self, msg: Any) -> None:
        self.mission_seq = msg.seq

    def on_mission_item_reached(self, msg: Any) -> None:
        self.last_reached = msg.seq

    def on_home_position(self, msg: Any) -> None:
        self.home = (msg.latitude / 1e7, msg.longitude / 1e7)

    def on_system_time(self, msg: Any) -> None:
        if msg.time_unix_usec:
            self.gps_clock_offset_s = msg.time_unix_usec / 1e6 - time.time()

    def on_statustext(self, msg: Any) -> None:
        text = msg.text if isinstance(msg.text, str) else msg.text.decode("ascii", "replace")
        self.statustext.append(text.rstrip("\x00"))
        log.info("autopilot says: %s", text)

    def reading_handler(self, source: ReadingSource) -> Callable[[Any], None]:
        def handle(msg: Any) -> None:
            value = getattr(msg, source.field, None)
            if isinstance(value, int | float) and math.isfinite(value):
                self.readings[source.name] = value * source.scale

        return handle

    def handlers(self, readings: tuple[ReadingSource, ...] = ()) -> dict[str, list[Callable]]:
        table: dict[str, list[Callable]] = {
            "HEARTBEAT": [self.on_heartbeat],
            "GLOBAL_POSITION_INT": [self.on_global_position_int],
            "SYS_STATUS": [self.on_sys_status],
            "MISSION_CURRENT": [self.on_mission_current],
            "MISSION_ITEM_REACHED": [self.on_mission_item_reached],
            "HOME_POSITION": [self.on_home_position],
            "SYSTEM_TIME": [self.on_system_time],
            "STATUSTEXT": [self.on_statustext],
        }
        for source in readings:
            table.setdefault(source.message, []).append(self.reading_handler(source))
        return table

    # -- the fix sent to the server ----------------------------------------------------------

    def fix(self, wall_now: float | None = None) -> dict[str, Any] | None:
        """The current fix for ``POST boat/telemetry/``, or None without a position or a clock.

        A position older than ``silent_after_s`` is not reported again under a new time: a
        silent autopilot shows on the server as a vessel gone quiet, not one sitting still.

        ``time`` is Unix seconds rounded to the millisecond (DESIGN §5 accepts either that or
        ISO 8601; this is half the bytes). The server dedupes on (vessel, time), and the same
        number always maps to the same instant, so a re-sent fix is a harmless duplicate.
        """
        lat, lon, position_at = self.lat, self.lon, self.position_at
        if lat is None or lon is None or position_at is None:
            return None
        if time.monotonic() - position_at > self.silent_after_s:
            return None
        now = time.time() if wall_now is None else wall_now
        if now < CLOCK_SANE_AFTER:
            if self.gps_clock_offset_s is None:
                return None
            now += self.gps_clock_offset_s
        fix: dict[str, Any] = {"time": round(now, 3), "lat": round(lat, 7), "lon": round(lon, 7)}
        if self.heading_deg is not None:
            fix["heading_deg"] = round(self.heading_deg, 2)
        if self.speed_mps is not None:
            fix["speed_mps"] = round(self.speed_mps, 2)
        if self.battery_v is not None:
            fix["battery_v"] = round(self.battery_v, 3)
        readings = {k: v for k, v in dict(self.readings).items() if math.isfinite(v)}
        readings["armed"] = 1 if self.armed else 0
        if self.mission_seq is not None:
            readings["mission_item"] = self.mission_seq
        if self.custom_mode is not None:
            readings["mode_number"] = self.custom_mode
        fix["readings"] = readings
        return fix
