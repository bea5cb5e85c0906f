"""The commands app's errors: one base, a person-readable message, optionally the field at fault.

Pure (no Django), so the catalog and the lifecycle can raise them. The API's one exception
handler (``fleet.api``) and the forms' adapter (``commands.forms.add_command_error``) turn them
into HTTP answers and form errors; views and admin actions do not catch them one by one.
"""

from __future__ import annotations

from edge_client.contract.status import Status


class CommandError(ValueError):
    """A command request that cannot be carried out; ``message`` says why, ``field`` where."""

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field

    def as_dict(self) -> dict[str, list[str]]:
        return {self.field or "non_field_errors": [self.message]}


class CatalogError(CommandError):
    """A command a person asked for is not valid (kind, parameters, ranges, text form)."""


class CommandNotFound(CommandError):
    """No such command for the asker (another vessel's command looks exactly the same)."""


class TransitionError(CommandError):
    """The command's status cannot move to ``target`` from where it is (docs/api.md#boat-api-v1)."""

    # ``str``: a Status (a StrEnum) is one. The names are the contract's, which lies below the
    # lifecycle, so reading it here ties no cycle.
    def __init__(self, current: str, target: str) -> None:
        if target == Status.CANCELLED:
            message = f"command is {current}; it can no longer be cancelled"
        else:
            message = f"command is {current}; it cannot become {target}"
        super().__init__(message, field="status")
        self.current = current
        self.target = target
