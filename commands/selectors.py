"""Command reads shared by the operator API and the admin."""

from __future__ import annotations

import uuid
from typing import Any

from commands.errors import CommandNotFound
from commands.models import Command


def command_by_uid(uid: Any) -> Command:
    """The command with ``uid``; CommandNotFound for a malformed or unknown uid alike."""
    try:
        return Command.objects.get(uid=uuid.UUID(str(uid)))
    except (ValueError, Command.DoesNotExist):
        raise CommandNotFound("No such command.") from None
