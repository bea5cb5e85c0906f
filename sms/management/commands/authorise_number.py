"""manage.py authorise_number <number> --vessel <slug> [--vessel …] --role query|control --name …"""

from __future__ import annotations

import argparse
import datetime as dt
from typing import Any

from django.core.exceptions import ValidationError
from django.core.management.base import CommandError, CommandParser

from audit.context import AuditedCommand
from sms.errors import SmsError
from sms.models import Role
from sms.services import authorised_number_authorise, validation_message
from vessels.models import Vessel


def _date(text: str) -> dt.date:
    try:
        return dt.date.fromisoformat(text)
    except ValueError:
        raise CommandError(f"--expires {text!r} is not a date (YYYY-MM-DD)") from None


class Command(AuditedCommand):  # audited as the shell user, via cli
    help = (
        "Authorise a phone number to text these vessels (exactly these: re-running replaces "
        "the list) with a role; it becomes active. Prints the E.164 number."
    )

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("number", help="E.164 (+61412345678) or national (0412 345 678)")
        parser.add_argument("--vessel", action="append", required=True, help="slug; repeatable")
        parser.add_argument("--role", choices=Role.values, required=True)
        parser.add_argument("--name", required=True, help="who holds the phone")
        parser.add_argument(
            "--expires", help="YYYY-MM-DD: the authorisation ends at the start of that day (UTC)"
        )
        parser.add_argument("--notes")
        parser.add_argument(
            "--positions",
            action=argparse.BooleanOptionalAction,
            help="texted the glider's position on the bridge's schedule (default: unchanged; "
            "a new number does not)",
        )

    def handle(self, *args: Any, **opts: Any) -> None:
        slugs = list(dict.fromkeys(opts["vessel"]))
        vessels = list(Vessel.objects.filter(slug__in=slugs))
        missing = sorted(set(slugs) - {v.slug for v in vessels})
        if missing:
            raise CommandError(f"no vessel {', '.join(repr(s) for s in missing)}")
        expires_at = None
        if opts["expires"]:
            expires_at = dt.datetime.combine(_date(opts["expires"]), dt.time(), tzinfo=dt.UTC)
        try:
            entry = authorised_number_authorise(
                number=opts["number"],
                vessels=vessels,
                role=opts["role"],
                name=opts["name"],
                expires_at=expires_at,
                notes=opts["notes"],
                receives_positions=opts["positions"],
            )
        except SmsError as exc:
            raise CommandError(exc.message) from None
        except ValidationError as exc:
            raise CommandError(validation_message(exc)) from None
        self.stderr.write(
            f"{entry.name} may text {', '.join(sorted(slugs))} ({entry.role})"
            + (f" until {entry.expires_at:%Y-%m-%d}" if entry.expires_at else "")
            + (", receives positions" if entry.receives_positions else "")
        )
        self.stdout.write(entry.number)
