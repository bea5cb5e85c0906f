from __future__ import annotations

from typing import Any

from django.core.management.base import BaseCommand

from sbd.services import sbd_send_queued
from sbd.transport import configured_transport


class Command(BaseCommand):
    help = "Hand the queued mobile-terminated SBD messages to the provider (one pass)."

    def handle(self, *args: Any, **opts: Any) -> None:
        if configured_transport() is None:
            self.stderr.write("no SBD MT transport: set SBD_ROCKBLOCK_USERNAME (and password)")
            return
        self.stdout.write(f"sent {sbd_send_queued()}")
