"""manage.py sms_inject --vessel <slug> --from <number> --text "…": try an SMS without a modem.

The SMS goes through the same service as one from the modem (sms_handle_incoming): it is
logged, its commands are queued. Each reply that would be sent is printed, one SMS per line;
-v 2 adds the outcome on stderr. Replies are stored as not to be sent, unless --send leaves
them for the modem loop. --modem-timestamp gives the modem's time stamp, so that a re-delivery
can be tried.

When the SMS is not carried out (a stranger; an inactive, expired or other vessel's number; a
query-role number commanding; the rate limit; a delivery handled before) the reason is written
on stderr and the exit status is 3 (NOT_ANSWERED). The one notice a rate-limited number gets
is printed like a reply: it is the SMS that would be sent.
"""

from __future__ import annotations

import datetime as dt
from typing import Any

from django.core.management.base import BaseCommand, CommandError, CommandParser
from django.utils import timezone
from django.utils.dateparse import parse_datetime

from sms.models import Outcome
from sms.services import SmsOutcome, sms_handle_incoming
from vessels.models import Vessel

# The exit status when the SMS gets no answer of its own (1 is Django's for a command error,
# 2 argparse's for bad arguments).
NOT_ANSWERED = 3
_CARRIED_OUT = frozenset({Outcome.ACCEPTED, Outcome.ERROR})


def not_answered_reason(result: SmsOutcome) -> str | None:
    """Why an SMS got no answer of its own, for the operator; None when it was answered."""
    message = result.message
    if result.duplicate:
        when = f"{message.received_at:%Y-%m-%d %H:%M:%S} UTC" if message.received_at else "before"
        return (
            f"no reply: delivered before (SMS {message.pk}, received {when}, "
            f"{message.outcome}); handled once"
        )
    if message.outcome in _CARRIED_OUT:
        return None
    if message.outcome == Outcome.STRANGER:
        return f"no reply: {message.number} is not an authorised number (logged as a stranger)"
    if message.outcome == Outcome.RATE_LIMITED:
        if result.replies:
            return f"rate limited ({message.detail}); the notice printed is its one reply"
        return f"no reply: rate limited ({message.detail}); the number was told once already"
    return f"no reply: refused ({message.detail})"


class Command(BaseCommand):
    help = (
        "Run an SMS through the SMS service and print the replies that would be sent; "
        f"exit status {NOT_ANSWERED} with the reason on stderr when it gets no answer."
    )

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--vessel", required=True, help="slug of the vessel texted")
        parser.add_argument("--from", dest="number", required=True, help="the sender's number")
        parser.add_argument("--text", required=True)
        parser.add_argument(
            "--send", action="store_true", help="leave the replies pending for the modem loop"
        )
        parser.add_argument(
            "--modem-timestamp",
            help="the modem's time stamp (ISO 8601 with offset): the same one twice is one SMS",
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
            modem_timestamp=_timestamp(opts["modem_timestamp"]),
            send_replies=opts["send"],
        )
        if not result.duplicate:  # a duplicate's replies went out (or not) the first time
            for text in result.reply_texts:
                self.stdout.write(text)
        reason = not_answered_reason(result)
        if reason is not None:
            raise CommandError(reason, returncode=NOT_ANSWERED)
        if opts["verbosity"] >= 2:  # the outcome, for the operator; never part of a reply
            detail = f" ({result.message.detail})" if result.message.detail else ""
            self.stderr.write(f"{result.outcome}{detail}; {len(result.commands)} command(s) queued")


def _timestamp(raw: str | None) -> dt.datetime | None:
    if raw is None:
        return None
    try:
        parsed = parse_datetime(raw)
    except ValueError:
        parsed = None
    if parsed is None or parsed.tzinfo is None:
        raise CommandError(f"--modem-timestamp {raw!r} is not a date-time with an offset")
    return parsed
