from __future__ import annotations

from typing import Any

from django.core.exceptions import ValidationError
from django.core.management.base import BaseCommand, CommandError, CommandParser

from vessels.models import VesselKind
from vessels.services import vessel_create


class Command(BaseCommand):
    help = "Create a vessel (for scripted provisioning)."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("slug")
        parser.add_argument("--name", required=True)
        parser.add_argument("--kind", choices=VesselKind.values, default=VesselKind.MAVLINK)
        parser.add_argument(
            "--period", type=int, default=60, help="expected seconds between reports"
        )
        parser.add_argument("--imei", help="its Iridium SBD modem's IMEI (15 digits)")

    def handle(self, *args: Any, **opts: Any) -> None:
        try:
            vessel = vessel_create(
                slug=opts["slug"],
                name=opts["name"],
                kind=opts["kind"],
                telemetry_period_s=opts["period"],
                imei=opts["imei"],
            )
        except ValidationError as exc:
            raise CommandError(
                "; ".join(f"{k}: {' '.join(v)}" for k, v in exc.message_dict.items())
            ) from None
        self.stdout.write(f"created vessel {vessel.slug} ({vessel.kind})")
