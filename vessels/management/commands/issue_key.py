from __future__ import annotations

from typing import Any

from django.core.exceptions import ValidationError
from django.core.management.base import CommandError, CommandParser

from audit.context import AuditedCommand, cli_origin
from vessels.models import Vessel
from vessels.services import vessel_key_issue


class Command(AuditedCommand):  # audited as the shell user, via cli
    help = "Issue a new key for a vessel; prints the key once, alone on its line."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("slug")
        parser.add_argument("--label", default="")

    def handle(self, *args: Any, **opts: Any) -> None:
        try:
            vessel = Vessel.objects.get(slug=opts["slug"])
        except Vessel.DoesNotExist:
            raise CommandError(f"no vessel {opts['slug']!r}") from None
        try:
            key, raw = vessel_key_issue(
                vessel=vessel, label=opts["label"], created_by=cli_origin().actor
            )
        except ValidationError as exc:
            raise CommandError(
                "; ".join(f"{k}: {' '.join(v)}" for k, v in exc.message_dict.items())
            ) from None
        self.stderr.write(f"key {key.prefix}… for {vessel.slug}; it is not shown again:")
        self.stdout.write(raw)
