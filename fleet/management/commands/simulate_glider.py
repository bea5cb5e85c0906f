"""The demo glider: the real Wave Glider bridge between a simulated C&C box, GSM modem and
payload board, reporting to a Shoreside under the glider's vessel key.

    SHORESIDE_DATA_DIR=…/glider manage.py simulate_glider --server http://127.0.0.1:8000 \\
        --key-file key-glider --start=-32.08,115.70

Run it with the *glider's* data folder (``SHORESIDE_DATA_DIR``): as on the glider's Pi, the
bridge keeps its own database there (migrated here, and given the vessel if it has none), and
learns its authorised numbers and commands from the shore. This process plays the hardware:

* the C&C box (``sms.level2.simulator``) on a pseudo-terminal, polling at the period the bridge
  declares and moving the glider as the commands it accepts say (``sms.level2.motion``);
* the GSM modem (``sms.modem.simulator``) on a second pseudo-terminal, with a control socket
  (``--control``) through which ``manage.py demo_sms`` has it receive an SMS;
* the payload board's UDP data servers (``sms.bridge.sensor_standin``) on free ports;

and ``manage.py run_wg_bridge`` runs as a child process on the two terminals, its shore link
to ``--server`` (the key goes in its environment: on the command line ``ps`` would show it).
SIGINT/SIGTERM stop the bridge (cleanly: it writes what it holds) and then the simulators.
Demo assembly, so it lives in ``fleet`` (the top floor).
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from django.conf import settings
from django.core.management import call_command
from django.core.management.base import BaseCommand, CommandError, CommandParser
from django.db import connections

from fleet.sim_options import start_position, vessel_key
from sms.bridge.records import RecordTable
from sms.bridge.sensor_standin import RecordServer, demo_values
from sms.level2.motion import Motion
from sms.level2.runner import PtyPort, SerialLink
from sms.level2.simulator import CcSimulator, RealClock, SimConfig
from sms.modem.control import ControlServer
from sms.modem.simulator import ModemServer, SimulatedModem
from vessels.models import Vessel, VesselKind
from vessels.services import vessel_create

STOP_TIMEOUT_S = 25.0  # the bridge joins its threads (10 s each at most) and writes what it holds
CONTROL_NAME = "modem.sock"
# The shore link's periods for a demo (seconds): an operator watches, so talk often.
SHORE_PERIODS = {"PUSH": 2, "POLL": 2, "SMS": 3, "NUMBERS": 60}


class Command(BaseCommand):
    help = "Run the Wave Glider bridge over simulated C&C, modem and sensors, for the demo."

    def add_arguments(self, parser: CommandParser) -> None:
        add = parser.add_argument
        add("--server", default="http://127.0.0.1:8000", help="the shore Shoreside")
        add("--key", help="the glider's vessel key there (or --key-file)")
        add("--key-file", help="file holding the vessel key")
        add("--vessel", default="glider", help="the glider's slug (here and on the shore)")
        add("--start", default="-32.0800,115.7000", help="lat,lon to start at (off Fremantle)")
        add("--heading", type=float, default=260.0, help="heading until commanded, degrees")
        add("--speed", type=float, default=1.0, help="speed through the water, m/s")
        add("--period", type=int, default=5, help="the C&C's poll period, s (the real one: 20)")
        add("--control", help=f"the modem's control socket (default: {CONTROL_NAME} here)")
        add("--duration", type=float, default=0.0, help="stop after this many seconds (0: never)")

    def handle(self, *args: Any, **opts: Any) -> None:
        key = vessel_key(opts)
        lat, lon = start_position(opts["start"])
        if not 1 <= opts["period"] <= 255:
            raise CommandError("--period must be 1..255 s")
        control = Path(opts["control"] or Path(settings.DATA_DIR) / CONTROL_NAME)
        self.prepare(opts["vessel"])
        logging.basicConfig(
            level=logging.INFO, format="%(asctime)s %(name)s %(message)s", stream=sys.stdout
        )
        self.stopping = False
        previous = {sig: signal.signal(sig, self._stop) for sig in (signal.SIGTERM, signal.SIGINT)}
        hardware = Hardware(Motion(lat, lon, opts["heading"] % 360, opts["speed"]), self.say)
        bridge: subprocess.Popen[bytes] | None = None
        died = False
        try:
            hardware.start(control)
            bridge = self.spawn(self.bridge_args(opts, hardware), self.bridge_env(opts, key))
            self.say(
                f"glider at {lat:.5f},{lon:.5f}: bridge pid {bridge.pid} → {opts['server']}; "
                f"C&C on {hardware.cc_port.name}, modem on {hardware.modem_server.url}, "
                f"SMS in through {control}"
            )
            died = self.wait(bridge, hardware, opts["duration"])
        finally:
            if bridge is not None:
                self.stop_child(bridge)
            hardware.stop()
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        if died and bridge is not None:
            raise CommandError(f"the bridge exited with {bridge.returncode}")
        self.say("simulated glider stopped")

    def prepare(self, slug: str) -> None:
        """The glider's own database, as its Pi would have it: migrated, with the vessel."""
        call_command("migrate", verbosity=0, interactive=False)
        vessel = Vessel.objects.filter(slug=slug).first()
        if vessel is None:
            vessel_create(slug=slug, name="Wave Glider", kind=VesselKind.WAVE_GLIDER)
        elif vessel.kind != VesselKind.WAVE_GLIDER:
            raise CommandError(f"vessel {slug!r} here is a {vessel.kind}, not a Wave Glider")
        connections.close_all()  # the bridge process uses the database from now on

    def say(self, line: str) -> None:
        self.stdout.write(f"{time.strftime('%H:%M:%S')} {line}")
        self.stdout.flush()

    def _stop(self, signum: int, frame: Any) -> None:
        self.stopping = True

    @staticmethod
    def bridge_args(opts: dict[str, Any], hardware: Hardware) -> list[str]:
        ports = ",".join(f"{name}={port}" for name, port in hardware.sensor_ports().items())
        return [
            "manage.py", "run_wg_bridge", "--vessel", opts["vessel"],
            "--level2-port", hardware.cc_port.name, "--modem-port", hardware.modem_server.url,
            "--poll-period", str(opts["period"]), "--result-timeout", str(6 * opts["period"]),
            "--sensor-host", "127.0.0.1", "--sensor-ports", ports,
        ]  # fmt: skip

    @staticmethod
    def bridge_env(opts: dict[str, Any], key: str) -> dict[str, str]:
        env = {"WG_SHORE_URL": opts["server"], "WG_SHORE_KEY": key}
        env.update({f"WG_SHORE_{name}_PERIOD_S": str(s) for name, s in SHORE_PERIODS.items()})
        return env

    def spawn(self, args: list[str], env: dict[str, str]) -> subprocess.Popen[bytes]:
        environ = {**os.environ, "PYTHONUNBUFFERED": "1", **env}
        environ.pop("NOTIFY_SOCKET", None)  # the child is not a systemd service
        # Its output goes where ours goes (the demo's glider log).
        return subprocess.Popen([sys.executable, *args], cwd=settings.BASE_DIR, env=environ)

    def wait(self, bridge: subprocess.Popen[bytes], hardware: Hardware, duration: float) -> bool:
        """Until a signal, ``duration`` or the bridge's end (True); reports the SMS sent."""
        deadline = time.monotonic() + duration if duration else None
        while not self.stopping:
            hardware.report_sent()
            if bridge.poll() is not None:
                return True
            if deadline is not None and time.monotonic() >= deadline:
                return False
            time.sleep(0.2)
        return False

    def stop_child(self, proc: subprocess.Popen[bytes]) -> None:
        if proc.poll() is None:
            proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.stderr.write(f"the bridge (pid {proc.pid}) did not stop; killing it")
            proc.kill()
            proc.wait()


class Hardware:
    """The glider's simulated C&C box, modem and payload board, in this process's threads."""

    def __init__(self, motion: Motion, say: Callable[[str], None]) -> None:
        self.motion = motion
        self.say = say
        self.cc_port = PtyPort(timeout=0.01)
        self.modem = SimulatedModem()
        self.modem_server = ModemServer(self.modem, "pty")
        table = RecordTable.load()
        self.boards = [
            RecordServer(record, demo_values(record), port=0) for record in table.records.values()
        ]
        self.control: ControlServer | None = None
        self.reported = 0

    def sensor_ports(self) -> dict[str, int]:
        return {board.record.name: board.port for board in self.boards}

    def start(self, control: Path) -> None:
        try:
            self.control = ControlServer(self.modem, control, on_sms=self._typed).start()
        except OSError as exc:
            raise CommandError(f"cannot listen at {control}: {exc}") from None
        self.modem_server.start()
        for board in self.boards:
            board.start()
        sim = CcSimulator(
            SerialLink(self.cc_port), SimConfig(motion=self.motion), RealClock(), self._trace
        )
        threading.Thread(target=self._run_cc, args=(sim,), name="c&c-sim", daemon=True).start()

    def stop(self) -> None:
        if self.control is not None:
            self.control.stop()
        self.modem_server.stop()
        for board in self.boards:
            board.stop()
        self.cc_port.close()  # the C&C thread (a daemon) ends with the process

    def report_sent(self) -> None:
        for sms in self.modem.sent[self.reported :]:
            self.say(f"modem: SMS sent to {sms.number}: {sms.text}")
            self.reported += 1

    def _typed(self, number: str, text: str, slot: int | None) -> None:
        where = f"slot {slot}" if slot is not None else "refused: SIM store full"
        self.say(f"modem: SMS from {number} arrives ({where}): {text}")

    def _trace(self, line: str) -> None:
        # Every status poll would be a line every few seconds: the rest is news.
        if "status-" not in line or " QUEUED" in line:
            self.say(f"C&C: {line}")

    def _run_cc(self, sim: CcSimulator) -> None:
        try:
            sim.run(float("inf"))
        except OSError as exc:  # the port closed as we stop
            self.say(f"C&C stopped: {exc}")
