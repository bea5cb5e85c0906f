"""The Wave Glider bridge as one long-running process (``manage.py run_wg_bridge``).

References: docs/wave-glider.md; issue 11 §1; healthchecks' ``sendalerts`` (a thin loop of
small ``do_one_<thing>()`` steps, signals that only set a flag, ``close_old_connections()``, a
failing item logged and pushed aside) and nobodd (configuration parsed once into a frozen
dataclass with clear ``ValueError``s, systemd notify).

Threads, so that nothing slow ever delays a Level 2 reply (the C&C retries after ~2 s; the real
board answered in 4–17 ms; §2, §10 of docs/level2.md):

* ``level2``: :class:`~sms.level2.runner.PayloadRunner`, the only code on the Level 2 port; it
  reopens the port when it goes away. Its notifications go to the :class:`Dispatcher`.
* ``modem``: :class:`~sms.bridge.sms_link.SmsLink` (SMS in, held replies, SMS out); the driver
  reopens a port that went away and resets a modem that went silent.
* ``sensors`` (with a sensor host): :class:`~sms.bridge.sensors.SensorSubscriber`.
* ``loops`` given to the bridge (the shore link's ``run(stop)``), each in a thread of its own:
  a slow shore server delays nothing else.
* the main thread: :meth:`Bridge.do_one_housekeeping` about once a second (command timeouts,
  fix batches, results the database refused, the position SMS on its schedule
  (:mod:`sms.bridge.positions`), ``close_old_connections``; a step that keeps failing is
  retried ever less often) and the systemd watchdog.

A stop (SIGTERM/SIGINT set the flag) ends the threads, then writes what is still in memory
(fixes, command results). Everything else is in the database as it happens: queued commands,
SMS in (deleted from the SIM only once stored), replies waiting or pending.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import serial
from django.db import DatabaseError, close_old_connections, connection

from edge_client import systemd
from edge_client.contract.backoff import UNTIL_THE_CAP, after_failures
from sms import selectors
from sms.level2.codec import Frame
from sms.level2.payload import (
    CommandCompleted,
    Notification,
    PayloadConfig,
    ResultWithoutCommand,
)
from sms.level2.runner import BAUDRATE, PayloadRunner
from sms.modem import Modem, ModemConfig
from vessels.keys import hash_key
from vessels.models import Vessel

from .commands import QUARANTINE_S, RESULT_TIMEOUT_S, DatabaseCommandSource
from .dispatch import Dispatcher
from .fixes import FixRecorder
from .machine import BridgeMachine
from .position_schedule import check_period
from .positions import PositionReporter
from .power import parse_command
from .records import RecordTable
from .sensors import LatestReadings, SensorSubscriber
from .sms_link import POLL_S, SmsLink

log = logging.getLogger(__name__)

POLL_PERIOD_S = 20  # declared at enumeration (§8.2, docs/level2.md: the real PIB's)
# The reply window's margin over one poll period: the request queued comes ~0.4 s after the
# flagged status reply and the C&C answered at once (§8.6, §9); the rest is for a retry (§10).
REPLY_MARGIN_S = 10.0
TICK_S = 1.0
RECONNECT_DELAY_S = 1.0
JOIN_S = 10.0
# A housekeeping step that keeps failing (a database away, a bug) is retried ever less often,
# up to this long apart: one line per retry, not a traceback every tick.
HOUSEKEEPING_RETRY_MAX_S = 30.0
# The C&C counts as silent (the position SMS says so) after this many poll periods without a
# request: it polls every period, and retries within seconds (§10).
CC_SILENT_POLLS = 3
ENV_PREFIX = "WG_"


def _modem_port(url: str, baudrate: int = BAUDRATE) -> Any:
    """The modem's port with a short read timeout: the modem thread's poll is its granularity
    (sms_link.POLL_S), so that a reply released by the C&C's ACK starts within milliseconds."""
    return serial.serial_for_url(url, baudrate=baudrate, timeout=POLL_S)


class HealingMachine(BridgeMachine):
    """The bridge's machine, which gets the Level 2 thread a new database connection after an
    error: nothing else in that thread would (close_old_connections runs per request in a web
    server). Costs nothing until an error; then one ``SELECT 1`` decides (CONN_HEALTH_CHECKS)."""

    # When the C&C last sent a request (time.monotonic()): how the bridge knows it is silent.
    last_request_at: float | None = None

    def handle(self, frame: Frame) -> list[Frame]:
        self.last_request_at = time.monotonic()
        if connection.errors_occurred:
            try:
                connection.close_if_unusable_or_obsolete()
            except DatabaseError:
                connection.close()
        return super().handle(frame)


@dataclass
class StepHealth:
    """A housekeeping step's failures in a row, and when to try it again after the last one."""

    failures: int = 0
    retry_at: float = 0.0


def housekeeping_retry_s(tick_s: float, failures: int) -> float:
    """How long a step that failed ``failures`` times in a row is left alone: the next tick
    after one failure, then doubling up to HOUSEKEEPING_RETRY_MAX_S."""
    cap = max(tick_s, HOUSEKEEPING_RETRY_MAX_S)
    return after_failures(tick_s, failures - 1, cap=cap, max_doublings=UNTIL_THE_CAP)


@dataclass(frozen=True)
class BridgeConfig:
    """What ``run_wg_bridge`` is told, from options or ``WG_*`` environment variables."""

    vessel: str
    level2_port: str
    modem_port: str
    poll_period_s: int = POLL_PERIOD_S
    reply_window_s: float | None = None  # None: one poll period plus REPLY_MARGIN_S
    result_timeout_s: float = RESULT_TIMEOUT_S
    quarantine_s: float = QUARANTINE_S
    sensor_host: str = ""  # empty: no sensor manager
    sensor_ports: Mapping[str, int] = field(default_factory=dict)  # record name → UDP port
    power_command: str = ""  # empty: a power-down notice is only logged
    # The shore server (issue 11 §6): WG_SHORE_URL and WG_SHORE_KEY, as sms.bridge.shore reads.
    shore_url: str = ""
    shore_key: str = field(default="", repr=False)  # a secret: never in a log line
    tick_s: float = TICK_S
    reconnect_delay_s: float = RECONNECT_DELAY_S
    # The glider's position by SMS to the numbers that receive positions (issue 20 §5): every
    # this many seconds, 0 = never.
    position_sms_period_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("vessel", "level2_port", "modem_port"):
            if not getattr(self, name):
                raise ValueError(f"{name} is required (--{name.replace('_', '-')})")
        if not 1 <= self.poll_period_s <= 255:  # one byte in the enumeration reply (§8.2)
            raise ValueError(f"poll_period_s must be 1..255, not {self.poll_period_s}")
        if self.reply_window_s is not None and self.reply_window_s < 0:
            raise ValueError("reply_window_s must be 0 or more")
        if self.result_timeout_s <= 0 or self.tick_s <= 0:
            raise ValueError("result_timeout_s and tick_s must be above 0")
        if bool(self.shore_url) != bool(self.shore_key):
            raise ValueError("the shore URL and key go together (--upstream-url, --upstream-key)")
        parse_command(self.power_command)  # a quoting mistake is a ValueError now, not later
        check_period(self.position_sms_period_s)

    @property
    def reply_window(self) -> float:
        if self.reply_window_s is not None:
            return self.reply_window_s
        return self.poll_period_s + REPLY_MARGIN_S

    @classmethod
    def from_env(cls, environ: Mapping[str, str] | None = None, **given: object) -> BridgeConfig:
        """Options given (not None) win over ``WG_<NAME>`` variables, which win over defaults."""
        environ = os.environ if environ is None else environ
        values: dict[str, object] = {}
        for spec in dataclasses.fields(cls):
            value = given.get(spec.name)
            raw = environ.get(ENV_PREFIX + spec.name.upper(), "")
            if value is None and raw:
                value = _from_text(spec.name, raw)
            if value is not None:
                values[spec.name] = value
        for name in ("vessel", "level2_port", "modem_port"):
            values.setdefault(name, "")
        return cls(**values)  # type: ignore[arg-type]


def _from_text(name: str, raw: str) -> object:
    try:
        if name == "poll_period_s":
            return int(raw)
        if name.endswith("_s"):
            return float(raw)
    except ValueError:
        raise ValueError(f"{ENV_PREFIX}{name.upper()}={raw!r} is not a number") from None
    if name == "sensor_ports":
        return parse_ports(raw)
    return raw


def parse_ports(text: str) -> dict[str, int]:
    """``stasis=4010,ctd=4011`` → ``{"stasis": 4010, "ctd": 4011}``."""
    ports: dict[str, int] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, _, port = item.partition("=")
        if not port.isdigit() or not 0 < int(port) < 65536:
            raise ValueError(f"sensor port {item!r}: give record=port, e.g. stasis=4010")
        ports[name.strip()] = int(port)
    return ports


class Bridge:
    """The glider's bridge for one vessel: build with a config, :meth:`run` until stopped."""

    def __init__(
        self,
        config: BridgeConfig,
        *,
        vessel: Vessel | None = None,
        loops: Sequence[tuple[str, Callable[[threading.Event], None]]] = (),
        level2_trace: Callable[[str], None] | None = None,
        modem_config: Mapping[str, object] | None = None,
        sms_options: Mapping[str, object] | None = None,
        position_options: Mapping[str, object] | None = None,
    ) -> None:
        self.config = config
        self.vessel = vessel or selectors.bridge_vessel(config.vessel)
        self.stop_event = threading.Event()
        self.readings = LatestReadings()
        self.source = DatabaseCommandSource(
            vessel=self.vessel,
            result_timeout_s=config.result_timeout_s,
            quarantine_s=config.quarantine_s,
        )
        self.machine = HealingMachine(
            PayloadConfig(poll_period_s=config.poll_period_s),
            source=self.source,
            sensors=self.readings.state,
        )
        self.fixes = FixRecorder(vessel=self.vessel, readings=self.readings.snapshot)
        self.dispatch = Dispatcher(
            machine=self.machine,
            source=self.source,
            fixes=self.fixes,
            power_command=parse_command(config.power_command),
        )
        self.runner = PayloadRunner(
            config.level2_port,
            self.machine,
            reconnect_delay_s=config.reconnect_delay_s,
            on_notification=self._notified,
            trace=level2_trace,
        )
        self.modem = Modem(
            ModemConfig(config.modem_port, **dict(modem_config or {})),  # type: ignore[arg-type]
            port_factory=_modem_port,
        )
        self.sms = SmsLink(
            vessel=self.vessel,
            modem=self.modem,
            reply_window_s=config.reply_window,
            readings=self.readings.snapshot,
            refresh=self.fixes.flush,
            # The shore signs its command SMS with this key's hash; no key, no shore SMS.
            shore_key_hash=hash_key(config.shore_key) if config.shore_key else None,
            **dict(sms_options or {}),  # type: ignore[arg-type]
        )
        self.started_at = time.monotonic()
        self.positions = PositionReporter(
            vessel=self.vessel,
            period_s=config.position_sms_period_s,
            nudge=self.sms.nudge,
            refresh=self.fixes.flush,
            cc_silent_s=self.cc_silent_s,
            **dict(position_options or {}),  # type: ignore[arg-type]
        )
        self.subscriber: SensorSubscriber | None = None
        if config.sensor_host:
            records = []
            for record in RecordTable.load().records.values():
                port = config.sensor_ports.get(record.name, record.port)
                records.append(dataclasses.replace(record, port=port))
            self.subscriber = SensorSubscriber(config.sensor_host, records, self.readings)
        self.step_health: dict[str, StepHealth] = {}
        # The housekeeping's clock (seconds); tests replace it.
        self.clock: Callable[[], float] = time.monotonic
        self.loops = list(loops)
        self.threads: list[threading.Thread] = []
        self.ticks = 0

    # -- the main loop --------------------------------------------------------------------------

    def run(self) -> int:
        """Start the threads, tick until stopped, stop cleanly. Returns the exit status."""
        self.start()
        systemd.ready(f"serving {self.config.level2_port} and {self.config.modem_port}")
        interval = systemd.watchdog_interval()
        last_ping = 0.0
        try:
            while not self.stop_event.is_set():
                self.do_one_housekeeping()
                if interval is not None and time.monotonic() - last_ping >= interval:
                    if all(t.is_alive() for t in self.threads):
                        systemd.watchdog()  # a dead thread stops the pings: systemd restarts us
                    last_ping = time.monotonic()
                self.stop_event.wait(self.config.tick_s)
        finally:
            systemd.stopping()
            self.shutdown()
        return 0

    def start(self) -> None:
        self._thread("level2", self._serve_level2)
        self._thread("modem", lambda: self.sms.run(self.stop_event))
        if self.subscriber is not None:
            self._thread("sensors", self._serve_sensors)
        for name, loop in self.loops:
            self._thread(name, lambda loop=loop: loop(self.stop_event))

    def stop(self) -> None:
        """What SIGTERM/SIGINT do: set the flag (safe in a signal handler)."""
        self.stop_event.set()

    def do_one_housekeeping(self) -> bool:
        """One tick of the main loop; True if it got through without a database error.

        A failing step is logged and left alone for a while (housekeeping_retry_s), the others
        carry on: its traceback is logged once, each later failure in one line."""
        self.ticks += 1
        steps: list[tuple[str, Callable[[], object]]] = [
            ("command timeouts", self._expire_overdue),
            ("fixes", self.fixes.flush_if_due),
            ("command results", self.source.flush_results),
            ("position SMS", self.positions.do_one),
        ]
        healthy = True
        now = self.clock()
        for name, step in steps:
            health = self.step_health.setdefault(name, StepHealth())
            if health.failures and now < health.retry_at:
                continue
            try:
                step()
            except DatabaseError as exc:
                healthy = False
                self._step_failed(name, health, now, f"database error: {exc}; reconnecting")
                connection.close()
            except Exception as exc:  # noqa: BLE001 - one failing step must not stop the others
                self._step_failed(name, health, now, repr(exc), traceback=True)
            else:
                if health.failures:
                    log.info("%s: working again after %d failure(s)", name, health.failures)
                    health.failures = 0
        close_old_connections()
        return healthy

    def _step_failed(
        self, name: str, health: StepHealth, now: float, what: str, *, traceback: bool = False
    ) -> None:
        health.failures += 1
        delay = housekeeping_retry_s(self.config.tick_s, health.failures)
        health.retry_at = now + delay
        if health.failures == 1:
            level = logging.ERROR if traceback else logging.WARNING
            log.log(level, "%s failed: %s", name, what, exc_info=traceback)
        else:
            log.warning(
                "%s failed again (%d in a row): %s; next try in %.1f s",
                name, health.failures, what, delay,
            )  # fmt: skip

    def shutdown(self) -> None:
        """Stop the threads, then write what is only in memory."""
        self.stop_event.set()
        self.runner.stop()
        for thread in self.threads:
            thread.join(JOIN_S)
            if thread.is_alive():
                log.error("thread %s did not stop within %.0f s", thread.name, JOIN_S)
        for name, flush in (("fixes", self.fixes.flush), ("results", self.source.flush_results)):
            try:
                flush()
            except DatabaseError as exc:
                log.error("could not write %s at stop: %s", name, exc)
        connection.close()

    def _notified(self, note: Notification) -> None:
        """The runner's callback (its thread): route the note, and when it ended a command,
        nudge the modem thread so the held reply goes out now, not at its next look."""
        self.dispatch(note)
        if isinstance(note, CommandCompleted | ResultWithoutCommand):
            self.sms.nudge()

    def cc_silent_s(self) -> float | None:
        """How long the C&C has not sent a request, when that is more than CC_SILENT_POLLS poll
        periods (counted from the start if it never did); None while it polls."""
        last = self.machine.last_request_at or self.started_at
        silent = time.monotonic() - last
        return silent if silent > CC_SILENT_POLLS * self.config.poll_period_s else None

    def _expire_overdue(self) -> None:
        if self.source.expire_overdue():
            self.sms.nudge()

    # -- threads --------------------------------------------------------------------------------

    def _thread(self, name: str, target: Callable[[], None]) -> None:
        thread = threading.Thread(target=target, name=f"wg-{name}", daemon=True)
        self.threads.append(thread)
        thread.start()

    def _serve_level2(self) -> None:
        try:
            self.runner.run()
        finally:
            connection.close()  # this thread's own connection

    def _serve_sensors(self) -> None:
        assert self.subscriber is not None
        while not self.stop_event.is_set():
            try:
                with self.subscriber as subscriber:
                    subscriber.run(self.stop_event)
            except OSError as exc:  # the network is not up yet: try again
                log.warning("sensors: %s", exc)
                self.stop_event.wait(self.config.reconnect_delay_s)
