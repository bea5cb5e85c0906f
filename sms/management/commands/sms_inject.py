"""manage.py sms_inject --vessel <slug> --from <number> --text "…": try an SMS without a modem.

The SMS goes through the same service as one from the modem (sms_handle_incoming): it is
logged, its commands are queued. Each reply that would be sent is printed, one SMS per line;
nothing at all is printed when none would be (a stranger, a refused number, a rate limit);
-v 2 adds the outcome on stderr.
Replies are stored as not to be sent, unless --send leaves them for the modem loop.
"""

from __future__ import annotations

from typing import Any

from django.core.management.base import BaseCommand, CommandError, CommandParser
from django.utils import timezone

from sms.services import sms_handle_incoming
from vessels.models import Vessel


class Command(BaseCommand):
    help = "Run an SMS through the SMS service and print the replies that would be sent."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--vessel", required=True, help="slug of the vessel texted")
        parser.add_argument("--from", dest="number", required=True, help="the sender's number")
        parser.add_argument("--text", required=True)
        parser.add_argument(
            "--send", action="store_true", help="leave the replies pending for the modem loop"
        )

    def handle(self, *args: Any, **opts: Any) -> None:
        try:
            vessel = Vessel.objects.get(slug=opts["vessel"])
        except Vessel.DoesNotExist:
            raise CommandError(f"no vessel {opts['vessel']!r}") from None
        result = sms_handle_incoming(
            vessel=vessel,
            number=opts["number"],
            text=opts["text"],
            received_at=timezone.now(),
            send_replies=opts["send"],
        )
        for text in result.reply_texts:
            self.stdout.write(text)
        if opts["verbosity"] >= 2:  # the outcome, for the operator; never part of a reply
            detail = f" ({result.message.detail})" if result.message.detail else ""
            self.stderr.write(f"{result.outcome}{detail}; {len(result.commands)} command(s) queued")
