"""One demo boat: the Rover MAVLink simulator and the real edge client, as two processes.

    manage.py simulate_boat --server http://127.0.0.1:8000 --key ssk_… --start=-31.979,115.817

starts ``python -m edge_client.sim --listen udpin:127.0.0.1:PORT`` (an ArduPilot-Rover-like
autopilot at the start position) and ``python -m edge_client run --mavlink udpout:…:PORT``
against the server, and stops both on SIGINT/SIGTERM. Everything a boat does (outbox, ETag
polls, acks, arming, MAVLink) is the edge client's own code: nothing is re-implemented here.
Give each boat its own ``--port``. Demo assembly, so it lives in ``fleet`` (the top floor).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from django.conf import settings
from django.core.management.base import BaseCommand, CommandError, CommandParser

from fleet.sim_options import start_position, vessel_key

STOP_TIMEOUT_S = 10.0  # the edge client's clean stop takes one poll or send at most
KEY_ENV = "SHORESIDE_EDGE_KEY"  # edge_client/config.py: the key stays out of `ps` output


class Command(BaseCommand):
    help = "Run a simulated Rover and the real edge client against a Shoreside server."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--server", default="http://127.0.0.1:8000")
        parser.add_argument("--key", help="vessel key (or --key-file)")
        parser.add_argument("--key-file", help="file holding the vessel key")
        parser.add_argument(
            "--start", default="-31.9790,115.8170", help="lat,lon to start at (Matilda Bay)"
        )
        parser.add_argument("--port", type=int, default=14550, help="UDP port of the simulator")
        parser.add_argument("--speed", type=float, default=2.0, help="boat speed, m/s")
        parser.add_argument(
            "--prearm-delay", type=float, default=5.0, help="seconds before the boat can arm"
        )
        parser.add_argument("--telemetry-period", type=float, default=5.0, help="seconds")
        parser.add_argument("--poll-period", type=float, default=5.0, help="seconds")
        parser.add_argument(
            "--outbox", help="edge client outbox file (default: in the data dir, per port)"
        )
        parser.add_argument(
            "--duration", type=float, default=0.0, help="stop after this many seconds (0: never)"
        )

    def handle(self, *args: Any, **opts: Any) -> None:
        key = vessel_key(opts)
        lat, lon = start_position(opts["start"])
        outbox = Path(opts["outbox"] or settings.DATA_DIR / f"demo-boat-{opts['port']}.sqlite3")
        self.stopping = False
        previous = {sig: signal.signal(sig, self._stop) for sig in (signal.SIGTERM, signal.SIGINT)}
        procs: dict[str, subprocess.Popen[bytes]] = {}
        died = None
        try:
            procs["simulator"] = self._spawn(self.sim_args(opts, lat, lon))
            procs["edge client"] = self._spawn(self.edge_args(opts, outbox), {KEY_ENV: key})
            self.stdout.write(
                f"boat at {lat:.5f},{lon:.5f}: simulator pid {procs['simulator'].pid} on UDP "
                f"{opts['port']}, edge client pid {procs['edge client'].pid} → {opts['server']}"
            )
            self.stdout.flush()
            died = self.wait(procs, opts["duration"])
        finally:
            self.stop_all(list(procs.values()))
            for sig, handler in previous.items():
                signal.signal(sig, handler)
        if died is not None:
            raise CommandError(f"the {died} exited with {procs[died].returncode}")
        self.stdout.write("simulated boat stopped")

    def _stop(self, signum: int, frame: Any) -> None:
        self.stopping = True

    @staticmethod
    def sim_args(opts: dict[str, Any], lat: float, lon: float) -> list[str]:
        return [
            "-m", "edge_client.sim", "--listen", f"udpin:127.0.0.1:{opts['port']}",
            "--lat", str(lat), "--lon", str(lon), "--speed", str(opts["speed"]),
            "--prearm-delay", str(opts["prearm_delay"]),
        ]  # fmt: skip

    @staticmethod
    def edge_args(opts: dict[str, Any], outbox: Path) -> list[str]:
        return [
            "-m", "edge_client", "run", "--server", opts["server"],
            "--mavlink", f"udpout:127.0.0.1:{opts['port']}", "--outbox", str(outbox),
            "--telemetry-period", str(opts["telemetry_period"]),
            "--poll-period", str(opts["poll_period"]),
        ]  # fmt: skip

    def _spawn(self, args: list[str], env: dict[str, str] | None = None) -> subprocess.Popen[bytes]:
        environ = {**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})}
        environ.pop("NOTIFY_SOCKET", None)  # our children are not the systemd service
        # Their output goes where ours goes (the demo's per-boat log file).
        return subprocess.Popen([sys.executable, *args], cwd=settings.BASE_DIR, env=environ)

    def wait(self, procs: dict[str, subprocess.Popen[bytes]], duration: float) -> str | None:
        """Until a signal, ``duration`` or a child's death; returns the name of one that died."""
        deadline = time.monotonic() + duration if duration else None
        while not self.stopping:
            for name, proc in procs.items():
                if proc.poll() is not None:
                    return name
            if deadline is not None and time.monotonic() >= deadline:
                return None
            time.sleep(0.2)
        return None

    def stop_all(self, procs: list[subprocess.Popen[bytes]]) -> None:
        """SIGTERM the edge client then the simulator; SIGKILL whatever will not go."""
        for proc in reversed(procs):
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in reversed(procs):
            try:
                proc.wait(STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                self.stderr.write(f"pid {proc.pid} did not stop; killing it")
                proc.kill()
                proc.wait()
