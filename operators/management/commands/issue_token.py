"""`manage.py issue_token <username> --name … [--expires-days N]`: prints the token once."""

from __future__ import annotations

from datetime import timedelta
from typing import Any

from django.contrib.auth import get_user_model
from django.core.exceptions import ValidationError
from django.core.management.base import CommandError, CommandParser

from audit.context import AuditedCommand
from operators.services import operator_token_issue

DEFAULT_EXPIRES_DAYS = 90


class Command(AuditedCommand):  # audited as the shell user, via cli
    help = "Issue a personal API token for an operator. The token is printed once, alone on stdout."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("username")
        parser.add_argument("--name", required=True, help="What or who uses the token.")
        parser.add_argument(
            "--expires-days",
            type=int,
            default=DEFAULT_EXPIRES_DAYS,
            help=f"Days until it expires [{DEFAULT_EXPIRES_DAYS}]; 0 = never.",
        )

    def handle(self, *args: Any, **options: Any) -> None:
        days = options["expires_days"]
        if days < 0:
            raise CommandError("--expires-days must be 0 (never) or more.")
        user_model = get_user_model()
        try:
            user = user_model.objects.get_by_natural_key(options["username"])
        except user_model.DoesNotExist:
            raise CommandError(f"No user {options['username']!r}.") from None
        try:
            token, raw = operator_token_issue(
                user=user, name=options["name"], expires_in=timedelta(days=days) if days else None
            )
        except ValidationError as exc:
            raise CommandError("; ".join(exc.messages)) from None
        expiry = token.expiry.isoformat(timespec="seconds") if token.expiry else "never"
        self.stderr.write(f"Token {token.name!r} for {user.get_username()}, expires {expiry}:")
        self.stdout.write(raw)
