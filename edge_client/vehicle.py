"""Vehicle state kept from MAVLink messages, one handler per message type.

As in the original SPAB client's Mavlink manager, each message type the client cares about has a
handler registered with the link; adding a sensor means registering one more handler (or
naming a ``[readings.*]`` source in the config). Handlers run on the link's reader thread and
only assign attributes, so readers on other threads see whole values (plain attribute writes
are atomic under the GIL); :meth:`VehicleState.fix` copies what it needs at once.

Message references (common.xml / ardupilotmega.xml): HEARTBEAT (base_mode bit
MAV_MODE_FLAG_SAFETY_ARMED = 128, custom_mode = Rover mode number), GLOBAL_POSITION_INT
(lat/lon degE7, vx/vy cm/s, hdg cdeg, 65535 = unknown), SYS_STATUS (voltage_battery mV,
65535 = unknown; onboard_control_sensors_* bits), MISSION_CURRENT, MISSION_ITEM_REACHED,
HOME_POSITION, GPS_GLOBAL_ORIGIN, SYSTEM_TIME, STATUSTEXT (pre-arm and mode-change failure
reasons), GPS_RAW_INT (fix_type), EKF_STATUS_REPORT (flags, ardupilotmega.xml EKF_STATUS_FLAGS),
FENCE_STATUS (breach_status, breach_count: the fence the autopilot enforces).
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

from edge_client.config import ReadingSource
from edge_client.contract.fix import FENCE_BREACH_COUNT, FENCE_BREACHED
from edge_client.contract.geo import distance_m
from edge_client.contract.kinds import ROVER_MODE_NAMES
from edge_client.mission import WaypointNumbers

log = logging.getLogger(__name__)

# HEARTBEAT custom_mode → name: the modes of the catalog plus the one seen while booting.
MODE_NAMES = ROVER_MODE_NAMES

MAV_MODE_FLAG_SAFETY_ARMED = 128
MAV_AUTOPILOT_INVALID = 8  # HEARTBEATs from GCSs and companions carry this; ignore them
UINT16_UNKNOWN = 65535
# Before this the Pi's clock has not been set (no RTC on a Pi Zero): trust the autopilot's.
CLOCK_SANE_AFTER = datetime(2024, 1, 1, tzinfo=UTC).timestamp()
# Position readiness, as Rover::ekf_position_ok() judges it for an armed vehicle:
# EKF_STATUS_FLAGS (ardupilotmega.xml), GPS_FIX_TYPE (common.xml), MAV_SYS_STATUS_SENSOR bits.
EKF_POS_HORIZ_REL = 8
EKF_POS_HORIZ_ABS = 16
EKF_CONST_POS_MODE = 128
GPS_FIX_TYPE_3D_FIX = 3
MAV_SYS_STATUS_SENSOR_GPS = 0x20
MAV_SYS_STATUS_AHRS = 0x200000
# ArduPilot sends FENCE_STATUS only while its fence is on: one older than this means it was
# switched off, and the fixes stop carrying the fence readings rather than repeat the last.
FENCE_STATUS_FRESH_S = 10.0


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
    # The operator's waypoint numbers of the last mission we uploaded: the fix reports the
    # current one ("waypoint" of "waypoints") beside the autopilot's own item ("mission_item").
    waypoints: WaypointNumbers | None = None
    home: tuple[float, float] | None = None
    time_boot_ms: int | None = None
    gps_clock_offset_s: float | None = None  # autopilot UTC (SYSTEM_TIME) minus our clock
    readings: dict[str, float] = field(default_factory=dict)
    statustext: deque[str] = field(default_factory=lambda: deque(maxlen=20))
    statustext_count: int = 0  # STATUSTEXTs ever received: "what came since" for a caller
    ekf_flags: int | None = None  # EKF_STATUS_REPORT.flags
    gps_fix_type: int | None = None  # GPS_RAW_INT.fix_type
    sensors_health: tuple[int, int] | None = None  # SYS_STATUS (enabled, health) bits
    origin: tuple[float, float] | None = None  # GPS_GLOBAL_ORIGIN: the EKF origin is set
    ekf_failsafe: bool = False  # the autopilot said "EKF failsafe" and not yet "… cleared"
    # FENCE_STATUS: None until the autopilot reports its fence (it does only while one is on).
    fence_breached: bool | None = None
    fence_breach_count: int = 0
    # breach_count when the last fix was taken: a breach that began and ended between two
    # fixes (the boat turned back at once) still shows in the next one.
    fence_breach_count_in_fix: int = 0
    fence_status_at: float | None = None  # time.monotonic() of the last FENCE_STATUS
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

    def statustext_since(self, count: int) -> list[str]:
        """The STATUSTEXTs received after ``statustext_count`` was ``count`` (at most 20)."""
        texts = list(self.statustext)
        return texts[len(texts) - min(len(texts), self.statustext_count - count) :]

    def position_ready(self) -> tuple[bool | None, str]:
        """Can the autopilot enter a mode that needs a position now? (yes/no/None, why).

        Mirrors Rover::ekf_position_ok() for an armed vehicle: the EKF has a horizontal
        position (absolute or relative) and is not in constant-position mode. Without
        EKF_STATUS_REPORT (older firmware, or not streamed yet) the weaker signals decide: a
        3D GPS fix, the AHRS health bit, an EKF origin or home. None: nothing to judge by.
        """
        if self.ekf_flags is not None:
            if self.ekf_flags & EKF_CONST_POS_MODE:
                return False, "EKF in constant-position mode (no position yet)"
            if not self.ekf_flags & (EKF_POS_HORIZ_ABS | EKF_POS_HORIZ_REL):
                return False, "EKF has no horizontal position yet"
            return True, "EKF has a horizontal position"
        if self.gps_fix_type is not None and self.gps_fix_type < GPS_FIX_TYPE_3D_FIX:
            return False, f"no 3D GPS fix yet (GPS_RAW_INT fix_type {self.gps_fix_type})"
        if self.sensors_health is not None:
            enabled, health = self.sensors_health
            for bit, name in ((MAV_SYS_STATUS_SENSOR_GPS, "GPS"), (MAV_SYS_STATUS_AHRS, "AHRS")):
                if enabled & bit and not health & bit:
                    return False, f"{name} not healthy yet (SYS_STATUS)"
        if self.gps_fix_type is None and self.sensors_health is None:
            return None, "the autopilot reports no EKF, GPS or sensor health status"
        if self.origin is None and self.home is None:
            return False, "no EKF origin or home yet"
        return True, "GPS fix and healthy sensors"

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
        enabled = msg.onboard_control_sensors_enabled & msg.onboard_control_sensors_present
        self.sensors_health = (enabled, msg.onboard_control_sensors_health)

    def on_ekf_status_report(self, msg: Any) -> None:
        self.ekf_flags = msg.flags

    def on_gps_raw_int(self, msg: Any) -> None:
        self.gps_fix_type = msg.fix_type

    def on_gps_global_origin(self, msg: Any) -> None:
        self.origin = (msg.latitude / 1e7, msg.longitude / 1e7)

    def on_fence_status(self, msg: Any) -> None:
        breached = bool(msg.breach_status)
        if breached and not self.fence_breached:
            log.warning("autopilot reports a fence breach (%d so far)", msg.breach_count)
        self.fence_breached, self.fence_breach_count = breached, msg.breach_count
        self.fence_status_at = time.monotonic()

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
        text = text.rstrip("\x00")
        self.statustext.append(text)
        self.statustext_count += 1
        said = text.lower()
        # Rover/ekf_check.cpp says "EKF failsafe" and "EKF failsafe cleared" (Copter words
        # them "EKF Failsafe: changed to …" and "EKF Failsafe Cleared").
        if said.startswith("ekf failsafe"):
            self.ekf_failsafe = not said.startswith("ekf failsafe cleared")
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
            "EKF_STATUS_REPORT": [self.on_ekf_status_report],
            "GPS_RAW_INT": [self.on_gps_raw_int],
            "GPS_GLOBAL_ORIGIN": [self.on_gps_global_origin],
            "FENCE_STATUS": [self.on_fence_status],
        }
        for source in readings:
            table.setdefault(source.message, []).append(self.reading_handler(source))
        return table

    # -- the fix sent to the server ----------------------------------------------------------

    def fix(self, wall_now: float | None = None) -> dict[str, Any] | None:
        """The current fix for ``POST boat/telemetry/``, or None without a position or a clock.

        A position older than ``silent_after_s`` is not reported again under a new time: a
        silent autopilot shows on the server as a vessel gone quiet, not one sitting still.

        ``time`` is Unix seconds rounded to the millisecond (docs/api.md accepts either that or
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
            number = self.waypoints.number(self.mission_seq) if self.waypoints else None
            if number is not None and self.waypoints is not None:
                readings["waypoint"], readings["waypoints"] = number, self.waypoints.count
        if self.custom_mode is not None:
            readings["mode_number"] = self.custom_mode
        heard = self.fence_status_at
        if heard is not None and time.monotonic() - heard <= FENCE_STATUS_FRESH_S:
            count = self.fence_breach_count
            # count < the last one: the autopilot rebooted and counts from 0 again.
            latched = self.fence_breached or count > self.fence_breach_count_in_fix
            readings[FENCE_BREACHED] = 1 if latched else 0
            readings[FENCE_BREACH_COUNT] = count
            self.fence_breach_count_in_fix = count
        fix["readings"] = readings
        return fix
