"""``manage.py demo_sms "+61400000001" "#FHEAD 230"``: text the demo glider.

The SMS arrives at the running demo's simulated GSM modem (``simulate_glider``, started by
``scripts/demo.sh``), as if the phone had sent it: the glider's bridge reads it, answers it and
queues its commands, and the shore's SMS log shows all three a few seconds later. The modem
listens on a socket in the demo glider's data folder (``<SHORESIDE_DATA_DIR>/glider/``), so run
this with the same ``SHORESIDE_DATA_DIR`` as the demo (the default is the same), or give
``--control``. ``seed_demo`` authorises +61400000001 to command the glider; any other number
is logged and never answered.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from django.conf import settings
from django.core.management.base import BaseCommand, CommandError, CommandParser

from fleet.management.commands.simulate_glider import CONTROL_NAME
from sms.modem.control import ControlError, NotListening, send_sms

GLIDER_DIR = "glider"  # scripts/demo.sh: the demo glider's own data folder in the shore's


def default_control() -> Path:
    return Path(settings.DATA_DIR) / GLIDER_DIR / CONTROL_NAME


class Command(BaseCommand):
    help = "Text the running demo's glider: the SMS arrives at its simulated modem."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument(
            "number", help="the sender, e.g. +61400000001 (authorised by seed_demo)"
        )
        parser.add_argument("text", help='the SMS, e.g. "#FHEAD 230" or "#STATUS"')
        parser.add_argument("--control", help=f"the modem's control socket ({default_control()})")

    def handle(self, *args: Any, **opts: Any) -> None:
        control = Path(opts["control"] or default_control())
        try:
            slot = send_sms(control, opts["number"], opts["text"])
        except NotListening as exc:
            raise CommandError(f"{exc}: is `bash scripts/demo.sh` running?") from None
        except ControlError as exc:
            raise CommandError(f"the modem refused the SMS: {exc}") from None
        where = f" (SIM slot {slot})" if slot is not None else ""
        self.stdout.write(
            f"SMS from {opts['number']} arrived at the glider's modem{where}: {opts['text']}\n"
            "Its reply and commands show in the SMS log (/admin/sms/smsmessage/) within seconds."
        )
