"""manage.py deauthorise_number <number>: the number is kept (the log names it) but inactive."""

from __future__ import annotations

from typing import Any

from django.core.management.base import CommandError, CommandParser

from audit.context import AuditedCommand
from sms.errors import SmsError
from sms.services import authorised_number_deauthorise


class Command(AuditedCommand):  # audited as the shell user, via cli
    help = "Stop answering a phone number: its entry stays, inactive, for the SMS log."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("number", help="in any form authorise_number accepts")

    def handle(self, *args: Any, **opts: Any) -> None:
        try:
            entry = authorised_number_deauthorise(number=opts["number"])
        except SmsError as exc:
            raise CommandError(exc.message) from None
        self.stderr.write(f"{entry.name} ({entry.number}) is no longer answered")
        self.stdout.write(entry.number)
