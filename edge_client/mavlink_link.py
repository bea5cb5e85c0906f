"""The MAVLink link to the autopilot: the only module that does pymavlink I/O.

One reader thread receives messages, dispatches them to the handlers registered per message type
(:class:`~edge_client.vehicle.VehicleState` keeps the vehicle state that way), sends our own
HEARTBEAT once a second (ArduPilot's GCS failsafe and ``udpin:`` peers both want one), notices a
silent autopilot and reopens a connection that failed (a USB serial adapter unplugged).
Request/response exchanges (COMMAND_LONG → COMMAND_ACK, the mission protocol) are run by the
caller's thread through a mailbox the reader fills; only one caller (the executor) uses them.

References (common.xml): HEARTBEAT, COMMAND_LONG / COMMAND_ACK (MAV_CMD_DO_SET_MODE,
MAV_CMD_COMPONENT_ARM_DISARM, MAV_CMD_SET_MESSAGE_INTERVAL, MAV_CMD_REQUEST_MESSAGE),
SET_POSITION_TARGET_GLOBAL_INT, MISSION_SET_CURRENT, REQUEST_DATA_STREAM (deprecated, still
honoured by ArduPilot, needed by old firmware).

MAVLink version: we start in MAVLink 1 (unless $MAVLINK20 is set) and pymavlink switches to
MAVLink 2 as soon as the autopilot's first frame is a v2 one. Forcing v2 would leave an old
v1-only firmware (like the original SPAB boat's APM2-era build) unable to parse us.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any, NamedTuple

from pymavlink import mavutil

from edge_client.config import MavlinkConfig, ReadingSource
from edge_client.contract.backoff import doubled
from edge_client.contract.kinds import ROVER_MODES
from edge_client.mission import MissionDownload, MissionItem, MissionUpload, Out
from edge_client.vehicle import VehicleState

log = logging.getLogger(__name__)

mavlink = mavutil.mavlink

# pymavlink's numbers (this module speaks MAVLink through it anyway).
MAV_CMD_DO_SET_MODE = mavlink.MAV_CMD_DO_SET_MODE
MAV_CMD_COMPONENT_ARM_DISARM = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
MAV_CMD_SET_MESSAGE_INTERVAL = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
MAV_CMD_REQUEST_MESSAGE = mavlink.MAV_CMD_REQUEST_MESSAGE
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
MAV_RESULT_ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
# COMMAND_ACK results by name, as messages say them. Written out, not pymavlink's enum: the
# pymavlink installed here (2.4.50) has no CANCELLED (6), which newer autopilots send.
MAV_RESULTS = {
    0: "ACCEPTED",
    1: "TEMPORARILY_REJECTED",
    2: "DENIED",
    3: "UNSUPPORTED",
    4: "FAILED",
    5: "IN_PROGRESS",
    6: "CANCELLED",
}
MAV_TYPE_ONBOARD_CONTROLLER = mavlink.MAV_TYPE_ONBOARD_CONTROLLER
MAV_AUTOPILOT_INVALID = mavlink.MAV_AUTOPILOT_INVALID
MAV_STATE_ACTIVE = mavlink.MAV_STATE_ACTIVE
MAV_FRAME_GLOBAL_RELATIVE_ALT_INT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
# POSITION_TARGET_TYPEMASK: ignore velocity, acceleration, yaw and yaw rate → a position target.
POSITION_ONLY_TYPEMASK = 0b0000_1101_1111_1000
# Messages the client wants streamed (id → rate divisor: 1 = full stream rate).
STREAMS = {
    "GLOBAL_POSITION_INT": 1,
    "SYS_STATUS": 4,
    "MISSION_CURRENT": 4,
    "SYSTEM_TIME": 8,
    # Position readiness after boot (VehicleState.position_ready).
    "EKF_STATUS_REPORT": 4,
    "GPS_RAW_INT": 4,
    # Breaches of the fence the autopilot enforces (ArduPilot sends it while a fence is on).
    "FENCE_STATUS": 4,
}
# REQUEST_DATA_STREAM groups for firmware without SET_MESSAGE_INTERVAL (MAV_DATA_STREAM_*).
MAV_DATA_STREAM_EXTENDED_STATUS = 2
MAV_DATA_STREAM_POSITION = 6
MAV_DATA_STREAM_EXTRA3 = 12  # ArduPilot sends EKF_STATUS_REPORT in this group
HOME_POSITION_ID = 242
GPS_GLOBAL_ORIGIN_ID = 49
MAILBOX_TYPES = frozenset(
    {
        "COMMAND_ACK",
        "MISSION_REQUEST",
        "MISSION_REQUEST_INT",
        "MISSION_ACK",
        "MISSION_COUNT",
        "MISSION_ITEM_INT",
        "MISSION_ITEM",
        "PARAM_VALUE",
    }
)
COMMAND_ACK_TIMEOUT_S = 1.0
COMMAND_RETRIES = 2
# PARAM_SET is answered by the PARAM_VALUE it set (mavlink.io parameter protocol): the value
# is sent as a float whatever its type (ArduPilot, MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT).
PARAM_TIMEOUT_S = 1.0
PARAM_RETRIES = 3


class LinkDown(Exception):
    """No autopilot to talk to."""


class ModeAnswer(NamedTuple):
    """The autopilot's answer to a mode change: accepted, the words, the COMMAND_ACK result
    (None: no ack at all)."""

    ok: bool
    detail: str
    result: int | None


class MavlinkLink:
    def __init__(self, config: MavlinkConfig, readings: tuple[ReadingSource, ...] = ()) -> None:
        self.config = config
        self.state = VehicleState(silent_after_s=config.silent_after_s, on_link_up=self._link_up)
        self._handlers: dict[str, list[Callable[[Any], None]]] = defaultdict(list)
        for msg_type, handlers in self.state.handlers(readings).items():
            for handler in handlers:
                self.on(msg_type, handler)
        self._extra_streams = {r.message for r in readings}
        self._mailbox: queue.Queue[Any] = queue.Queue(maxsize=500)
        self._conn: Any = None
        self._send_lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._streams_wanted = False
        self.messages_received = 0
        self.alive_at = time.monotonic()  # reader-thread progress, for the systemd watchdog

    # -- lifecycle ----------------------------------------------------------------------------

    def on(self, msg_type: str, handler: Callable[[Any], None]) -> None:
        """Register ``handler(msg)`` for every message of ``msg_type`` (e.g. "SYS_STATUS")."""
        self._handlers[msg_type].append(handler)

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="mavlink-reader", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread:
            self._thread.join(timeout=5)
        self._close()

    def is_alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def wait_heartbeat(self, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.state.autopilot_ok():
                return True
            time.sleep(0.05)
        return False

    def _open(self) -> None:
        self._conn = mavutil.mavlink_connection(
            self.config.connection,
            baud=self.config.baud,
            source_system=self.config.source_system,
            source_component=self.config.source_component,
            dialect="ardupilotmega",
        )
        log.info("MAVLink connection open: %s", self.config.connection)

    def _close(self) -> None:
        conn, self._conn = self._conn, None
        if conn is not None:
            try:
                conn.close()
            except OSError:
                pass

    def _run(self) -> None:
        backoff = 1.0
        last_heartbeat_sent = 0.0
        while not self._stop.is_set():
            self.alive_at = time.monotonic()
            if self._conn is None:
                try:
                    self._open()
                    backoff = 1.0
                except Exception as exc:  # pymavlink raises plain Exceptions for bad devices
                    log.warning(
                        "cannot open %s: %s (retry in %.0f s)", self.config.connection, exc, backoff
                    )
                    self._stop.wait(backoff)
                    backoff = doubled(backoff, cap=30.0)
                    continue
            now = time.monotonic()
            try:
                if now - last_heartbeat_sent >= 1.0:
                    last_heartbeat_sent = now
                    self._send_heartbeat()
                if self._streams_wanted:
                    self._streams_wanted = False
                    self._request_streams()
                msg = self._conn.recv_match(blocking=True, timeout=0.1)
            except Exception as exc:  # OSError, serial.SerialException, pymavlink errors
                log.warning("MAVLink connection failed: %s; reopening", exc)
                self._close()
                self._stop.wait(backoff)
                continue
            self.state.check_silence(time.monotonic())
            if msg is not None:
                self._dispatch(msg)

    def _dispatch(self, msg: Any) -> None:
        msg_type = msg.get_type()
        if msg_type == "BAD_DATA":
            return
        self.messages_received += 1
        for handler in self._handlers.get(msg_type, ()):
            try:
                handler(msg)
            except Exception:
                log.exception("handler for %s failed", msg_type)
        if msg_type in MAILBOX_TYPES and msg.get_srcSystem() == self.state.system:
            try:
                self._mailbox.put_nowait(msg)
            except queue.Full:  # nobody is waiting: drop the oldest
                self._mailbox.get_nowait()
                self._mailbox.put_nowait(msg)

    # -- sending ------------------------------------------------------------------------------

    def _send(self, name: str, *args: Any, **kwargs: Any) -> None:
        conn = self._conn
        if conn is None:
            raise LinkDown("MAVLink connection is not open")
        with self._send_lock:
            getattr(conn.mav, f"{name}_send")(*args, **kwargs)

    def target(self) -> tuple[int, int]:
        """(system, component) of the autopilot; LinkDown if it is not talking to us."""
        if self.state.system is None or not self.state.autopilot_ok():
            raise LinkDown("no HEARTBEAT from the autopilot")
        return self.state.system, self.state.component

    def _send_heartbeat(self) -> None:
        self._send(
            "heartbeat", MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID, 0, 0, MAV_STATE_ACTIVE
        )

    def _link_up(self) -> None:
        # Called on the reader thread from the HEARTBEAT handler; do the sending in the loop.
        self._streams_wanted = True

    def _request_streams(self) -> None:
        """Ask for the messages we need: SET_MESSAGE_INTERVAL per message, the old
        REQUEST_DATA_STREAM groups for firmware that predates it, and HOME_POSITION and
        GPS_GLOBAL_ORIGIN once (ArduPilot also sends both by itself when they get set)."""
        system, component = self.state.system or 1, self.state.component
        rate = self.config.stream_rate_hz
        groups = (
            (MAV_DATA_STREAM_POSITION, rate),
            (MAV_DATA_STREAM_EXTENDED_STATUS, 1),
            (MAV_DATA_STREAM_EXTRA3, 1),
        )
        for group, hz in groups:
            self._send("request_data_stream", system, component, group, max(1, round(hz)), 1)
        wanted = dict(STREAMS)
        wanted.update({name: 4 for name in self._extra_streams})
        for name, divisor in wanted.items():
            msg_id = getattr(mavlink, f"MAVLINK_MSG_ID_{name}", None)
            if msg_id is None:
                log.warning("unknown MAVLink message %s in [readings]", name)
                continue
            interval_us = 1e6 * divisor / rate
            self._send(
                "command_long",
                system,
                component,
                MAV_CMD_SET_MESSAGE_INTERVAL,
                0,
                msg_id,
                interval_us,
                0,
                0,
                0,
                0,
                0,
            )
        self.request_message(HOME_POSITION_ID)
        self.request_message(GPS_GLOBAL_ORIGIN_ID)

    def request_message(self, msg_id: int) -> None:
        """MAV_CMD_REQUEST_MESSAGE, fire and forget (the answer goes to its handler)."""
        system, component = self.state.system or 1, self.state.component
        self._send(
            "command_long", system, component, MAV_CMD_REQUEST_MESSAGE, 0, msg_id, 0, 0, 0, 0, 0, 0
        )

    # -- request/response (executor thread only) ---------------------------------------------

    def _drain(self) -> None:
        while True:
            try:
                self._mailbox.get_nowait()
            except queue.Empty:
                return

    def _next_message(self, timeout: float) -> Any | None:
        try:
            return self._mailbox.get(timeout=max(0.0, timeout))
        except queue.Empty:
            return None

    def command_long(
        self,
        command: int,
        *params: float,
        timeout: float = COMMAND_ACK_TIMEOUT_S,
        retries: int = COMMAND_RETRIES,
    ) -> int | None:
        """Send COMMAND_LONG and return the COMMAND_ACK result (None: no ack after retries).

        A re-send increments ``confirmation``, as the MAVLink command protocol asks.
        """
        system, component = self.target()
        padded = (list(params) + [0.0] * 7)[:7]
        self._drain()
        for confirmation in range(retries + 1):
            self._send("command_long", system, component, command, confirmation, *padded)
            deadline = time.monotonic() + timeout
            while (remaining := deadline - time.monotonic()) > 0:
                msg = self._next_message(remaining)
                if msg is not None and msg.get_type() == "COMMAND_ACK" and msg.command == command:
                    if msg.result == 5:  # MAV_RESULT_IN_PROGRESS: a final ack will follow
                        deadline = time.monotonic() + timeout
                        continue
                    return msg.result
        return None

    def set_mode(self, name: str) -> ModeAnswer:
        """MAV_CMD_DO_SET_MODE with the Rover custom mode; ok once the autopilot accepts it."""
        number = ROVER_MODES[name]
        said = self.state.statustext_count
        result = self.command_long(MAV_CMD_DO_SET_MODE, MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number)
        if result is None:
            return ModeAnswer(False, f"no COMMAND_ACK for mode {name}", None)
        if result != MAV_RESULT_ACCEPTED:
            # Rover says why in a STATUSTEXT sent before the COMMAND_ACK ("Flight mode change
            # failed"); the reader thread ran its handler before the ack reached us.
            reasons = "; ".join(dict.fromkeys(self.state.statustext_since(said)))
            why = f" ({reasons})" if reasons else ""
            words = f"autopilot refused mode {name}: {MAV_RESULTS.get(result, result)}{why}"
            return ModeAnswer(False, words, result)
        # ArduPilot acks only after the mode changed; the next HEARTBEAT (≤ 1 s) will agree.
        self.state.custom_mode = number
        return ModeAnswer(True, f"mode {name}", result)

    def arm(self, timeout: float, stop: threading.Event | None = None) -> tuple[bool, str]:
        """Arm, retrying while pre-arm checks fail, until ``timeout`` (ArduPilot's checks can
        take tens of seconds after a cold start, docs/edge-client.md#commands)."""
        deadline = time.monotonic() + timeout
        last = ""
        while True:
            result = self.command_long(MAV_CMD_COMPONENT_ARM_DISARM, 1)
            if result == MAV_RESULT_ACCEPTED:
                self.state.armed = True  # acked after arming; HEARTBEAT confirms within 1 s
                return True, "armed"
            prearm = [t for t in self.state.statustext if "arm" in t.lower()]
            last = prearm[-1] if prearm else f"arming {MAV_RESULTS.get(result, 'not acked')}"
            if time.monotonic() >= deadline or (stop is not None and stop.is_set()):
                return False, f"not armed within {timeout:.0f} s: {last}"
            time.sleep(min(1.0, max(0.0, deadline - time.monotonic())))

    def disarm(self) -> tuple[bool, str]:
        result = self.command_long(MAV_CMD_COMPONENT_ARM_DISARM, 0)
        if result == MAV_RESULT_ACCEPTED:
            self.state.armed = False
            return True, "disarmed"
        return False, f"disarm refused: {MAV_RESULTS.get(result, 'no COMMAND_ACK')}"

    def goto(self, lat: float, lon: float) -> None:
        """A GUIDED position target (SET_POSITION_TARGET_GLOBAL_INT, position-only mask).

        Preferred over velocity/heading targets, which Rover drops after ~3 s without refresh.
        ArduPilot sends no ack for it; the caller watches the position instead.
        """
        system, component = self.target()
        self._send(
            "set_position_target_global_int",
            0,
            system,
            component,
            MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            POSITION_ONLY_TYPEMASK,
            int(round(lat * 1e7)),
            int(round(lon * 1e7)),
            0,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        )

    def set_mission_current(self, seq: int) -> None:
        system, component = self.target()
        self._send("mission_set_current", system, component, seq)

    def _send_out(self, out: Out, mission_type: int = 0) -> None:
        system, component = self.target()
        self._send(
            out.type.lower(),
            target_system=system,
            target_component=component,
            mission_type=mission_type,
            **out.fields,
        )

    def _run_machine(self, machine: MissionUpload | MissionDownload) -> None:
        self._drain()
        for out in machine.start(time.monotonic()):
            self._send_out(out, machine.mission_type)
        while not machine.done:
            msg = self._next_message(min(0.05, machine.deadline - time.monotonic()))
            now = time.monotonic()
            outs = machine.handle(msg.get_type(), msg.to_dict(), now) if msg is not None else []
            outs += machine.poll(now)
            for out in outs:
                self._send_out(out, machine.mission_type)

    def upload_mission(self, items: list[MissionItem], mission_type: int = 0) -> MissionUpload:
        """Run a mission upload to completion; the returned machine says ok/result/error.
        ``mission_type`` MAV_MISSION_TYPE_FENCE uploads the geofence the same way."""
        machine = MissionUpload(items, mission_type=mission_type)
        self._run_machine(machine)
        return machine

    def download_mission(self, mission_type: int = 0) -> MissionDownload:
        machine = MissionDownload(mission_type=mission_type)
        self._run_machine(machine)
        return machine

    def param_set(self, name: str, value: float, param_type: int) -> float | None:
        """PARAM_SET, re-sent until the autopilot answers with that parameter's PARAM_VALUE;
        returns the value it now holds (None: no answer, or no such parameter: ArduPilot
        ignores a PARAM_SET of a name it does not know)."""
        system, component = self.target()
        self._drain()
        for _ in range(PARAM_RETRIES + 1):
            self._send("param_set", system, component, name.encode(), float(value), param_type)
            deadline = time.monotonic() + PARAM_TIMEOUT_S
            while (remaining := deadline - time.monotonic()) > 0:
                msg = self._next_message(remaining)
                if msg is not None and msg.get_type() == "PARAM_VALUE":
                    said = msg.param_id
                    said = said if isinstance(said, str) else said.decode("ascii", "replace")
                    if said.rstrip("\x00") == name:
                        return float(msg.param_value)
        return None
