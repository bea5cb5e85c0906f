from __future__ import annotations

from typing import Any

from django.core.management.base import CommandError, CommandParser

from audit.context import AuditedCommand
from vessels.models import VesselKey
from vessels.services import vessel_key_revoke


class Command(AuditedCommand):  # audited as the shell user, via cli
    help = "Revoke a vessel's keys: one by its prefix, or all with --all."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("slug")
        parser.add_argument("prefix", nargs="?", help="the key's first characters (ssk_…)")
        parser.add_argument("--all", action="store_true", help="revoke every key of the vessel")

    def handle(self, *args: Any, **opts: Any) -> None:
        keys = VesselKey.objects.filter(vessel__slug=opts["slug"], revoked_at__isnull=True)
        if opts["prefix"]:
            keys = keys.filter(prefix__startswith=opts["prefix"][:12])
        elif not opts["all"]:
            raise CommandError("name a key prefix, or pass --all")
        if not keys:
            raise CommandError("no matching active key")
        for key in keys:
            vessel_key_revoke(key=key)
            self.stdout.write(f"revoked {key.prefix}…")
