"""manage.py run_wg_bridge: the Wave Glider bridge on the glider's payload Pi (docs/wave-glider.md).

Every option may come from the environment instead (``WG_VESSEL``, ``WG_LEVEL2_PORT``, …; see
``sms/bridge/glider.env.example``); an option given on the command line wins. SIGTERM and
SIGINT only set a flag: the bridge stops its threads and writes what it holds.
"""

from __future__ import annotations

import dataclasses
import signal
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from django.core.management.base import BaseCommand, CommandError, CommandParser

from sms.bridge.process import Bridge, BridgeConfig, parse_ports
from sms.bridge.shore import ShoreLink
from sms.bridge.shore_config import ShoreConfig
from vessels.models import Vessel


class Command(BaseCommand):
    help = "Run the Wave Glider bridge: Level 2 to the C&C box, SMS through the modem, sensors."

    def add_arguments(self, parser: CommandParser) -> None:
        add = parser.add_argument
        add("--vessel", help="slug of the glider (WG_VESSEL)")
        add("--level2-port", help="C&C serial port: device, socket://, pty path (WG_LEVEL2_PORT)")
        add("--modem-port", help="GSM modem: device, socket://host:port (WG_MODEM_PORT)")
        add("--poll-period", dest="poll_period_s", type=int, help="declared poll period, s")
        add("--reply-window", dest="reply_window_s", type=float, help="wait for outcome, s")
        add("--result-timeout", dest="result_timeout_s", type=float, help="C&C answer, s")
        add("--sensor-host", help="the payload board's address for the UDP data servers")
        add("--sensor-ports", type=parse_ports, help="record=port,… (default: the layout's)")
        add("--power-command", help="run on a power-down notice (default: log only)")
        add(
            "--position-sms-period",
            dest="position_sms_period_s",
            type=float,
            help="text the position to the numbers that receive positions every this many "
            "seconds (0: never, the default; at least 60)",
        )
        add("--upstream-url", dest="shore_url", help="shore server URL (WG_SHORE_URL)")
        add(
            "--upstream-key",
            dest="shore_key",
            help="the glider's vessel key there; shown by ps to every user of the Pi, so prefer "
            "WG_SHORE_KEY in the environment or --upstream-key-file",
        )
        add("--upstream-key-file", help="a file holding the vessel key (instead of --upstream-key)")

    def handle(self, *args: Any, **opts: Any) -> None:
        if opts.get("upstream_key_file") and not opts.get("shore_key"):
            try:
                opts["shore_key"] = Path(opts["upstream_key_file"]).read_text().strip()
            except OSError as exc:
                raise CommandError(f"cannot read the key file: {exc}") from None
        names = (
            "vessel", "level2_port", "modem_port", "poll_period_s", "reply_window_s",
            "result_timeout_s", "sensor_host", "sensor_ports", "power_command", "shore_url",
            "shore_key", "position_sms_period_s",
        )  # fmt: skip
        try:
            config = BridgeConfig.from_env(**{name: opts.get(name) for name in names})
        except ValueError as exc:
            raise CommandError(str(exc)) from None
        try:
            vessel = Vessel.objects.get(slug=config.vessel)
        except Vessel.DoesNotExist:
            raise CommandError(f"no vessel {config.vessel!r}") from None
        bridge = Bridge(config, vessel=vessel, loops=shore_loops(config, vessel))
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, lambda _sig, _frame: bridge.stop())
        self.stdout.write(
            f"wg bridge for {vessel.slug}: Level 2 on {config.level2_port}, "
            f"modem on {config.modem_port}, reply window {config.reply_window:g} s"
            + (
                f", position SMS every {config.position_sms_period_s:g} s"
                if config.position_sms_period_s
                else ""
            )
        )
        bridge.run()
        self.stdout.write("wg bridge stopped")


def shore_loops(
    config: BridgeConfig, vessel: Vessel
) -> list[tuple[str, Callable[[threading.Event], None]]]:
    """The shore link's loop (issue 11 §6, ``sms.bridge.shore``) when a shore is configured."""
    if not config.shore_url:
        return []
    base = ShoreConfig.from_env() or ShoreConfig(url=config.shore_url, key=config.shore_key)
    shore = dataclasses.replace(base, url=config.shore_url, key=config.shore_key)
    return [("shore", ShoreLink(vessel=vessel, config=shore).run)]
