"""An ArduPilot-Rover-like MAVLink vehicle for tests and demos, on pymavlink.

It behaves like ArduPilot Rover where the edge client depends on it (docs/missions.md,
docs/edge-client.md#commands, mavlink.io common.xml), not like a physics model:

- HEARTBEAT (MAV_TYPE_SURFACE_BOAT, MAV_AUTOPILOT_ARDUPILOTMEGA, SAFETY_ARMED flag, Rover
  custom mode), GLOBAL_POSITION_INT at the stream rate, SYS_STATUS (battery), MISSION_CURRENT,
  SYSTEM_TIME, SCALED_PRESSURE (a temperature to map into ``readings``); SET_MESSAGE_INTERVAL
  and REQUEST_MESSAGE / GET_HOME_POSITION are honoured.
- Mission protocol in both directions, with MAV_MISSION_RESULT error codes: upload answered by
  requesting each item with the older MISSION_REQUEST (as a real Rover 4.7 does) or
  MISSION_REQUEST_INT (``request_int=True``), re-requesting on a 0.5 s timeout and cancelling after
  8 s; download answered with MISSION_ITEM_INT (item 0 = current home).
- COMMAND_LONG: DO_SET_MODE (COMMAND_ACK; AUTO refused without a mission), COMPONENT_ARM_DISARM
  (pre-arm checks fail with a "PreArm:" STATUSTEXT until ``prearm_delay_s`` after start),
  DO_SET_MISSION_CURRENT; MISSION_SET_CURRENT; SET_POSITION_TARGET_GLOBAL_INT in GUIDED.
- Start-up: the GPS gets its 3D fix, the EKF origin and home are set (GPS_GLOBAL_ORIGIN and
  HOME_POSITION are sent) at half ``position_delay_s``; the EKF's horizontal position is good
  only at ``position_delay_s`` ("EKF3 IMU0 is using GPS"). Armed without a good position for
  ``EKF_CHECK_S``, the EKF failsafe is raised ("EKF failsafe"; a mode that needs a position
  is left for HOLD); it clears ``ekf_failsafe_s`` after the position is good ("EKF failsafe
  cleared"), as Rover/ekf_check.cpp counts its bad checks back down, or on disarming. Until the
  position is good and the failsafe clear, while armed, a change to a mode that needs a
  position is refused as Rover does (Rover/mode.cpp ``Mode::enter``: ``requires_position()``
  and not ``ekf_position_ok() && !failsafe.ekf``; disarmed, Rover skips the check): STATUSTEXT
  "Flight mode change failed" and COMMAND_ACK FAILED. So a real Rover's start-up order, the
  position a second before the failsafe clears, happens here too. Readiness shows in
  EKF_STATUS_REPORT flags (CONST_POS_MODE, then POS_HORIZ_ABS), GPS_RAW_INT fix_type and
  SYS_STATUS health bits (GPS, AHRS). ``position_delay_s`` 0 is a warm start: all good at once.
- Motion at ``speed_mps`` (Rover's WP_SPEED) toward the GUIDED target, home in RTL/SMART_RTL
  ("Reached destination" on arrival, then it stays in the mode and holds there, as a boat
  loiters), and along the mission in AUTO as Rover/mode_auto.cpp and AP_Mission run it:
  NAV_WAYPOINT and NAV_LOITER_TIME reached within ``wp_radius_m`` (WP_RADIUS: Rover keeps no
  per-waypoint radius), then held there param1 whole seconds with the item still current;
  NAV_RETURN_TO_LAUNCH drives home inside AUTO (the mode stays AUTO, "Reached destination");
  DO commands run at once when the navigation command before them is done, DO_CHANGE_SPEED
  setting the speed from then on (param2 m/s; below 0.05 m/s, so -1 or 0, it is ignored, as
  AR_WPNav::set_speed_max refuses it; entering a mode, RTL included, goes back to WP_SPEED);
  DO_JUMP to its target param2 more times (-1 forever); MISSION_ITEM_REACHED when an item is
  done (after its hold), MISSION_CURRENT carrying the current navigation item; at the end
  "Mission Complete" and the boat stops, still in AUTO (MIS_DONE_BEHAVE 0). Only when armed.
  ``events`` records arrivals, items done and speed changes on the simulator's own clock.
- The geofence (:mod:`edge_client.sim.fence`): fence uploads and downloads, FENCE_* parameters,
  breaches reported (FENCE_STATUS, STATUSTEXT) and acted on (FENCE_ACTION) as Rover does.
- Missions are kept as AP_Mission keeps them (``stored``, in :mod:`edge_client.sim.mission`
  with the mission protocol): a download hands back what Rover
  would, not simply what was sent.
- Fault injection: ``drop`` / ``dup`` probabilities for messages (drop applies both ways),
  ``refuse_modes`` (COMMAND_ACK DENIED), ``reject_mission`` (MISSION_ACK with that code after
  the last item), ``lose`` (message names never sent, e.g. MISSION_ITEM_REACHED), ``muted``
  (stops talking, as a silent autopilot).
- Time: everything above (motion, stream rates, start-up delays, holds, the upload's retry and
  give-up, SYSTEM_TIME and time_boot_ms) is read from one :class:`~edge_client.sim.clock.SimClock`,
  the host's by default; ``time_scale`` (or a ``clock`` of a test's own) runs the vehicle's
  world faster than real time with the same messages in the same order.
"""

from __future__ import annotations

import math
import os
import random
import threading
from collections import deque
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil  # noqa: E402

from edge_client.contract.geo import bearing_deg, distance_m, offset  # noqa: E402 (pure)
from edge_client.contract.kinds import ROVER_MODE_NAMES, ROVER_POSITION_MODES  # noqa: E402 (pure)
from edge_client.sim.clock import ScaledClock, SimClock  # noqa: E402
from edge_client.sim.fence import FenceSim  # noqa: E402
from edge_client.sim.mission import (  # noqa: E402 (after MAVLINK20 is chosen)
    FIRST_ITEM,
    MAX_MISSION_ITEMS,
    NAV_LOITER_TIME,
    NAV_RTL,
    Event,
    Item,
    MissionProtocol,
)

mavlink = mavutil.mavlink

MODE_NAMES = ROVER_MODE_NAMES  # every mode Rover reports, by number
MODES = {name: number for number, name in MODE_NAMES.items()}
DEFAULT_WP_RADIUS_M = 2.0  # ArduPilot Rover WP_RADIUS default
# MISSION_CURRENT.mission_state (common.xml MISSION_STATE)
NO_MISSION, NOT_STARTED, ACTIVE, COMPLETE = 1, 2, 3, 5
POSITION_MODES = ROVER_POSITION_MODES  # refused (and left for HOLD) without a position
# EKF_STATUS_REPORT flags (ardupilotmega.xml EKF_STATUS_FLAGS) before and after the EKF has a
# horizontal position; SYS_STATUS sensor bits (common.xml MAV_SYS_STATUS_SENSOR).
EKF_STARTING = (mavlink.EKF_ATTITUDE | mavlink.EKF_VELOCITY_HORIZ | mavlink.EKF_CONST_POS_MODE
                | mavlink.EKF_PRED_POS_HORIZ_REL)  # fmt: skip
EKF_POSITION_OK = (mavlink.EKF_ATTITUDE | mavlink.EKF_VELOCITY_HORIZ | mavlink.EKF_VELOCITY_VERT
                   | mavlink.EKF_POS_HORIZ_REL | mavlink.EKF_POS_HORIZ_ABS
                   | mavlink.EKF_POS_VERT_ABS | mavlink.EKF_PRED_POS_HORIZ_REL
                   | mavlink.EKF_PRED_POS_HORIZ_ABS)  # fmt: skip
SENSORS = mavlink.MAV_SYS_STATUS_SENSOR_GPS | mavlink.MAV_SYS_STATUS_AHRS
GPS_FIX_NONE, GPS_FIX_3D = 1, 3
# Rover/ekf_check.cpp: 10 checks at 10 Hz (EKF_CHECK_ITERATIONS_MAX) of a bad position raise
# the EKF failsafe; as many good ones, counted back down, clear it (ekf_failsafe_s here).
EKF_CHECK_S = 1.0
EKF_FAILSAFE_CLEAR_S = 1.0
EKF_USING_GPS = "EKF3 IMU0 is using GPS"  # AP_NavEKF3 when it starts fusing GPS


class RoverSim(FenceSim, MissionProtocol):
    def __init__(
        self,
        endpoints: list[str],
        *,
        lat: float = -31.9800,
        lon: float = 115.8200,
        speed_mps: float = 2.0,
        rate_hz: float = 4.0,
        prearm_delay_s: float = 20.0,
        position_delay_s: float = 0.0,
        ekf_failsafe_s: float = EKF_FAILSAFE_CLEAR_S,
        request_int: bool = False,
        drop: float = 0.0,
        dup: float = 0.0,
        refuse_modes: tuple[str, ...] = (),
        reject_mission: int | None = None,
        lose: tuple[str, ...] = (),
        max_items: int = MAX_MISSION_ITEMS,
        wp_radius_m: float = DEFAULT_WP_RADIUS_M,
        seed: int | None = None,
        system: int = 1,
        time_scale: float = 1.0,
        clock: SimClock | None = None,
    ) -> None:
        # One clock for the whole vehicle: a faster one speeds up motion, streams, start-up and
        # mission timeouts together, so their order stays what it is in real time.
        self.clock = clock or ScaledClock(time_scale)
        self.conns = [
            mavutil.mavlink_connection(
                ep, source_system=system, source_component=1, dialect="ardupilotmega"
            )
            for ep in endpoints
        ]
        self.lat, self.lon = lat, lon
        self.home = (lat, lon)
        self.cruise_speed = speed_mps  # WP_SPEED: what every mode starts with
        self.speed = speed_mps  # now, after any DO_CHANGE_SPEED
        self.wp_radius = wp_radius_m
        self.heading = 0.0
        self.vn = self.ve = 0.0  # m/s north/east
        self.mode = MODES["HOLD"]
        self.armed = False
        self.target: tuple[float, float] | None = None
        self.mission: list[Item] = []
        self.current = 0  # the current navigation item (MISSION_CURRENT)
        self.nav_loaded = False  # False: find the navigation item from ``current`` on first
        self.arrived_at: float | None = None  # when the current item was reached (its hold)
        self.complete = False
        self.jumps: dict[int, int] = {}  # DO_JUMP seq → times followed
        self.events: deque[Event] = deque(maxlen=1000)
        self.battery_v = 12.6
        self.request_int = request_int
        self.drop, self.dup = drop, dup
        self.refuse_modes = {m.upper() for m in refuse_modes}
        self.reject_mission = reject_mission
        self.lose = {name.upper() for name in lose}  # message names never sent
        self.max_items = max_items
        self.prearm_delay_s = prearm_delay_s
        self.position_delay_s = position_delay_s  # a test may lower it to make the EKF ready
        self.ekf_failsafe_s = ekf_failsafe_s
        self.ekf_failsafe = False  # Rover's failsafe.ekf
        self._ekf_since: float | None = None  # when the EKF check last turned bad or good
        self._ekf_was_ok: bool | None = None  # for the "using GPS" text; None: not looked yet
        self._home_announced = False
        self.rtl_arrived = False
        self.muted = False
        self.rng = random.Random(seed)
        self.boot = self.clock.monotonic()
        self.intervals = {  # message id → seconds
            mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 1 / rate_hz,
            mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
            mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
            mavlink.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
            mavlink.MAVLINK_MSG_ID_SCALED_PRESSURE: 1.0,
            mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
            mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT: 1.0,
            mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
            mavlink.MAVLINK_MSG_ID_FENCE_STATUS: 1.0,  # while the fence is on (sim/fence.py)
        }
        self.last_sent: dict[int, float] = {}
        self.upload: dict[str, Any] | None = None  # in-progress upload
        self.uploaded: dict[str, Any] | None = None  # the last finished one, to re-ack
        self.peers: dict[int, tuple[int, int]] = {}
        self.counts = {"sent": 0, "dropped": 0, "duplicated": 0, "received": 0}
        self._last_step = self.clock.monotonic()
        self._lock = threading.Lock()
        self._fence_init()

    # -- running ------------------------------------------------------------------------------

    def run(self, stop: threading.Event) -> None:
        while not stop.is_set():
            self.step()
            stop.wait(0.005)
        self.close()

    def close(self) -> None:
        for conn in self.conns:
            conn.close()

    def step(self, now: float | None = None) -> None:
        """One turn: read, move, stream. ``now`` (the clock's monotonic scale) lets a test
        drive the simulator step by step at the times it chooses."""
        with self._lock:
            now = self.clock.monotonic() if now is None else now
            for conn in self.conns:
                while (msg := conn.recv_msg()) is not None:
                    self._receive(conn, msg, now)
            self._ekf_check(now)
            self._physics(now - self._last_step, now)
            self._last_step = now
            self._fence_check(now)
            self._upload_timeouts(now)
            self._streams(now)

    @property
    def mode_name(self) -> str:
        return MODE_NAMES.get(self.mode, str(self.mode))

    def boot_ms(self) -> int:
        return int((self.clock.monotonic() - self.boot) * 1000)

    def gps_fixed(self, now: float) -> bool:
        """GPS 3D fix, EKF origin and home set: half way to a good position estimate."""
        return now - self.boot >= self.position_delay_s / 2

    def position_ok(self, now: float) -> bool:
        """Rover's ``ekf_position_ok()`` for an armed vehicle."""
        return now - self.boot >= self.position_delay_s

    def _ekf_check(self, now: float) -> None:
        """Rover's ekf_check (ekf_check.cpp), coarsely: while armed, ``EKF_CHECK_S`` without a
        good position raises the failsafe; ``ekf_failsafe_s`` of a good one clears it."""
        ok = self.position_ok(now)
        if ok and self._ekf_was_ok is False:  # a warm start (good at once) says nothing
            self.statustext(None, EKF_USING_GPS, 6)
        self._ekf_was_ok = self._ekf_was_ok or ok
        if not self.armed:
            self._ekf_since = None
            self._ekf_failsafe_off()  # ekf_check clears it when disarmed
            return
        bad = not ok
        if self.ekf_failsafe == bad:
            self._ekf_since = None  # nothing to count: the state matches the EKF
            return
        if self._ekf_since is None:
            self._ekf_since = now
        if bad and now - self._ekf_since >= EKF_CHECK_S:
            self.ekf_failsafe, self._ekf_since = True, None
            if self.mode_name in POSITION_MODES:  # FS_EKF_ACTION 1: Hold
                self.mode = MODES["HOLD"]
            self.statustext(None, "EKF failsafe", 2)
        elif not bad and now - self._ekf_since >= self.ekf_failsafe_s:
            self._ekf_failsafe_off()

    def _ekf_failsafe_off(self) -> None:
        if self.ekf_failsafe:
            self.ekf_failsafe, self._ekf_since = False, None
            self.statustext(None, "EKF failsafe cleared", 2)

    # -- sending with fault injection ---------------------------------------------------------

    def _emit(self, conn: Any, name: str, *args: Any, **kwargs: Any) -> None:
        targets = self.conns if conn is None else [conn]
        if self.muted:
            return
        for c in targets:
            msg = getattr(c.mav, f"{name}_encode")(*args, **kwargs)
            if self.rng.random() < self.drop or name.upper() in self.lose:
                self.counts["dropped"] += 1
                continue
            copies = 2 if self.rng.random() < self.dup else 1
            self.counts["duplicated"] += copies - 1
            for _ in range(copies):
                try:
                    c.mav.send(msg)
                    self.counts["sent"] += 1
                except OSError:
                    pass  # a udpout peer not listening yet, a TCP peer gone: like a radio

    def statustext(self, conn: Any, text: str, severity: int = 4) -> None:
        self._emit(conn, "statustext", severity, text.encode()[:50])

    # -- streams ------------------------------------------------------------------------------

    def _due(self, msg_id: int, now: float) -> bool:
        interval = self.intervals.get(msg_id)
        if interval is None or interval <= 0:
            return False
        if now - self.last_sent.get(msg_id, -1e9) >= interval:
            self.last_sent[msg_id] = now
            return True
        return False

    def _streams(self, now: float) -> None:
        if self._due(mavlink.MAVLINK_MSG_ID_HEARTBEAT, now):
            base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
                mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0
            )
            state = mavlink.MAV_STATE_ACTIVE if self.armed else mavlink.MAV_STATE_STANDBY
            self._emit(
                None,
                "heartbeat",
                mavlink.MAV_TYPE_SURFACE_BOAT,
                mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                base,
                self.mode,
                state,
            )
            self.battery_v -= 0.0005
        if self._due(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, now):
            self._emit(
                None,
                "global_position_int",
                self.boot_ms(),
                int(self.lat * 1e7),
                int(self.lon * 1e7),
                0,
                0,
                int(self.vn * 100),
                int(self.ve * 100),
                0,
                int(self.heading * 100) % 36000,
            )
        if self.gps_fixed(now) and not self._home_announced:
            # AP_AHRS::set_home sends the new home and EKF origin to every GCS.
            self._home_announced = True
            self._send_home(None)
            self._send_origin(None)
        if self._due(mavlink.MAVLINK_MSG_ID_EKF_STATUS_REPORT, now):
            flags = EKF_POSITION_OK if self.position_ok(now) else EKF_STARTING
            self._emit(None, "ekf_status_report", flags, 0.1, 0.1, 0.1, 0.1, 0.0)
        if self._due(mavlink.MAVLINK_MSG_ID_GPS_RAW_INT, now):
            fix = GPS_FIX_3D if self.gps_fixed(now) else GPS_FIX_NONE
            lat, lon = (int(self.lat * 1e7), int(self.lon * 1e7)) if fix == GPS_FIX_3D else (0, 0)
            self._emit(None, "gps_raw_int", int(self.clock.time() * 1e6), fix, lat, lon, 0, 120,
                       200, 0, 0, 10 if fix == GPS_FIX_3D else 0)  # fmt: skip
        if self._due(mavlink.MAVLINK_MSG_ID_SYS_STATUS, now):
            healthy = (mavlink.MAV_SYS_STATUS_SENSOR_GPS if self.gps_fixed(now) else 0) | (
                mavlink.MAV_SYS_STATUS_AHRS if self.position_ok(now) else 0
            )
            self._emit(
                None,
                "sys_status",
                SENSORS,
                SENSORS,
                healthy,
                100,
                int(self.battery_v * 1000),
                150,
                80,
                0,
                0,
                0,
                0,
                0,
                0,
            )
        if self._due(mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, now):
            self._send_current()
        if self._due(mavlink.MAVLINK_MSG_ID_SYSTEM_TIME, now):
            self._emit(None, "system_time", int(self.clock.time() * 1e6), self.boot_ms())
        if self._due(mavlink.MAVLINK_MSG_ID_SCALED_PRESSURE, now):
            self._emit(None, "scaled_pressure", self.boot_ms(), 1013.25, 0.0, 1850)

    def _send_current(self, seq: int | None = None) -> None:
        """MISSION_CURRENT: the current navigation item, the item count (home excluded) and the
        mission state, as ArduPilot 4.4+ fills them in."""
        if len(self.mission) <= 1:
            state = NO_MISSION
        elif self.complete:
            state = COMPLETE
        else:
            state = ACTIVE if self.mode_name == "AUTO" and self.nav_loaded else NOT_STARTED
        seq = self.current if seq is None else seq
        self._emit(None, "mission_current", seq, max(0, len(self.mission) - 1), state)

    def _send_home(self, conn: Any) -> None:
        self._emit(
            conn,
            "home_position",
            int(self.home[0] * 1e7),
            int(self.home[1] * 1e7),
            0,
            0,
            0,
            0,
            [1, 0, 0, 0],
            0,
            0,
            0,
        )

    def _send_origin(self, conn: Any) -> None:
        lat, lon = self.home
        self._emit(conn, "gps_global_origin", int(lat * 1e7), int(lon * 1e7), 0,
                   int(self.clock.time() * 1e6))  # fmt: skip

    # -- motion -------------------------------------------------------------------------------

    def _drive_to(self, lat: float, lon: float, dt: float) -> float:
        """Move toward (lat, lon) for dt seconds; returns the distance left."""
        bearing = bearing_deg(self.lat, self.lon, lat, lon)
        dist = distance_m(self.lat, self.lon, lat, lon)
        step = self.speed * dt
        if dist < 0.01:
            self.vn = self.ve = 0.0
            return dist
        self.heading = bearing
        if step >= dist:
            self.lat, self.lon = lat, lon
            self.vn = self.ve = 0.0
            return 0.0
        b = math.radians(bearing)
        self.lat, self.lon = offset(self.lat, self.lon, bearing, step)
        self.vn, self.ve = self.speed * math.cos(b), self.speed * math.sin(b)
        return dist - step

    def _physics(self, dt: float, now: float) -> None:
        name = self.mode_name
        if not self.armed or dt <= 0:
            self.vn = self.ve = 0.0
            return
        if name == "GUIDED" and self.target:
            self._drive_to(*self.target, dt)
        elif name == "AUTO":
            self._auto(dt, now)
        elif name in ("RTL", "SMART_RTL"):
            left = self._drive_to(*self.home, dt)
            if left <= self.wp_radius and not self.rtl_arrived:
                self.rtl_arrived = True  # Rover/mode_rtl.cpp: once, then a boat loiters there
                self.statustext(None, "Reached destination", 6)
        else:
            self.vn = self.ve = 0.0

    def _auto(self, dt: float, now: float) -> None:
        """Rover's ModeAuto::update with AP_Mission::update, for the commands Shoreside uses."""
        if self.complete or (not self.nav_loaded and not self._advance(self.current, now)):
            self.vn = self.ve = 0.0  # MIS_DONE_BEHAVE 0: stop, still in AUTO
            return
        item = self.mission[self.current]
        rtl = item.command == NAV_RTL
        hold = 0 if rtl else int(item.param1)  # whole seconds, as AP_Mission keeps it
        if self.arrived_at is None:
            left = self._drive_to(*(self.home if rtl else (item.x / 1e7, item.y / 1e7)), dt)
            if left > self.wp_radius:
                return
            self.arrived_at = now
            self.events.append(Event(now, "arrived", item.seq))
            if rtl:
                text = "Reached destination"  # mode_rtl.cpp, run as Auto's RTL sub-mode
            elif hold:
                text = f"Reached waypoint #{item.seq}. Loiter for {hold} seconds"
            else:
                text = f"Reached waypoint #{item.seq}"
            self.statustext(None, text, 6)
        self.vn = self.ve = 0.0  # a boat loiters at the waypoint while it holds
        if now - self.arrived_at < hold:
            return
        if item.command == NAV_LOITER_TIME:
            self.statustext(None, "Finished active loiter", 4)
        self._item_done(item, now)
        self.nav_loaded = False
        self._advance(item.seq + 1, now)

    # -- receiving ----------------------------------------------------------------------------

    def _receive(self, conn: Any, msg: Any, now: float) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA":
            return
        if self.rng.random() < self.drop:
            self.counts["dropped"] += 1
            return
        self.counts["received"] += 1
        if id(conn) not in self.peers:  # a new peer: greet it now rather than within 1 s
            self.last_sent.pop(mavlink.MAVLINK_MSG_ID_HEARTBEAT, None)
        self.peers[id(conn)] = (msg.get_srcSystem(), msg.get_srcComponent())
        handler = getattr(self, f"_on_{kind.lower()}", None)
        if handler is not None:
            handler(conn, msg, now)

    def _peer(self, conn: Any) -> tuple[int, int]:
        """(system, component) of whoever last talked to us on ``conn``: replies target it."""
        return self.peers.get(id(conn), (255, 190))

    def _ack(self, conn: Any, command: int, result: int) -> None:
        self._emit(conn, "command_ack", command, result, 0, 0, *self._peer(conn))

    def _on_command_long(self, conn: Any, msg: Any, now: float) -> None:
        c = msg.command
        if c == mavlink.MAV_CMD_DO_SET_MODE:
            self._ack(conn, c, self._set_mode(conn, int(msg.param2), now))
        elif c == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            self._ack(conn, c, self._arm(conn, msg.param1 >= 0.5, now))
        elif c == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            msg_id, interval_us = int(msg.param1), msg.param2
            if interval_us < 0:
                self.intervals[msg_id] = 0
            elif interval_us > 0:
                self.intervals[msg_id] = interval_us / 1e6
            self._ack(conn, c, mavlink.MAV_RESULT_ACCEPTED)
        elif c in (mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAV_CMD_GET_HOME_POSITION):
            wanted = int(msg.param1) if c == mavlink.MAV_CMD_REQUEST_MESSAGE else 242
            senders = {
                mavlink.MAVLINK_MSG_ID_HOME_POSITION: self._send_home,
                mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: self._send_origin,
            }
            if wanted not in senders:
                self._ack(conn, c, mavlink.MAV_RESULT_UNSUPPORTED)
            elif not self.gps_fixed(now):
                self._ack(conn, c, mavlink.MAV_RESULT_FAILED)  # no home/origin yet
            else:
                self._ack(conn, c, mavlink.MAV_RESULT_ACCEPTED)
                senders[wanted](conn)
        elif c == mavlink.MAV_CMD_DO_SET_MISSION_CURRENT:
            ok = 0 <= int(msg.param1) < len(self.mission)
            if ok:
                self._set_current(int(msg.param1))
            self._ack(conn, c, mavlink.MAV_RESULT_ACCEPTED if ok else mavlink.MAV_RESULT_DENIED)
        else:
            self._ack(conn, c, mavlink.MAV_RESULT_UNSUPPORTED)

    def _on_set_mode(self, conn: Any, msg: Any, now: float) -> None:
        self._set_mode(conn, msg.custom_mode, now)  # SET_MODE has no ack of its own

    def _set_mode(self, conn: Any, number: int, now: float) -> int:
        name = MODE_NAMES.get(number)
        if name is None:
            return mavlink.MAV_RESULT_FAILED
        if name in self.refuse_modes:
            self.statustext(conn, f"Mode change to {name} refused")
            return mavlink.MAV_RESULT_DENIED
        position_ok = self.position_ok(now) and not self.ekf_failsafe
        if self.armed and name in POSITION_MODES and not position_ok:
            self.statustext(conn, "Flight mode change failed")  # Rover::set_mode
            return mavlink.MAV_RESULT_FAILED
        if name == "AUTO" and len(self.mission) <= 1:
            self.statustext(conn, "AutoMode: no mission")
            return mavlink.MAV_RESULT_FAILED
        if name == "AUTO":
            # ModeAuto::_enter → start_or_resume: a finished mission starts again from item 1,
            # a stopped one resumes its current item from the start.
            if self.complete or self.current < FIRST_ITEM:
                self.current, self.jumps, self.complete = FIRST_ITEM, {}, False
            self.nav_loaded, self.arrived_at = False, None
        self.speed = self.cruise_speed  # every mode's wp_nav.init() starts at WP_SPEED
        if name == "GUIDED":
            self.target = None  # Rover holds position until given a target
        if name in ("RTL", "SMART_RTL"):
            self.rtl_arrived = False
        self.mode = number
        return mavlink.MAV_RESULT_ACCEPTED

    def _arm(self, conn: Any, arm: bool, now: float) -> int:
        if not arm:
            self.armed = False
            return mavlink.MAV_RESULT_ACCEPTED
        if now - self.boot < self.prearm_delay_s:
            self.statustext(conn, "PreArm: Waiting for position estimate", 3)
            return mavlink.MAV_RESULT_FAILED
        self.armed = True
        return mavlink.MAV_RESULT_ACCEPTED

    def _on_set_position_target_global_int(self, conn: Any, msg: Any, now: float) -> None:
        position_ignored = msg.type_mask & 0b111 == 0b111
        if self.mode_name == "GUIDED" and not position_ignored:
            self.target = (msg.lat_int / 1e7, msg.lon_int / 1e7)
