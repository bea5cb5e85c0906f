"""The vessels app's errors (pure): one base, a person-readable message and, where one request
has several things wrong (a mission's checks, a file's unsupported items), every one of them.

``fleet.api`` turns them into HTTP answers; the admin shows ``problems`` as messages.
"""

from __future__ import annotations


class VesselsError(ValueError):
    """A request about vessels or missions that cannot be carried out."""

    field = "non_field_errors"

    def __init__(self, message: str, *, problems: list[str] | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.problems = list(problems) if problems else [message]

    def as_dict(self) -> dict[str, list[str]]:
        return {self.field: self.problems}


class MissionCheckError(VesselsError):
    """A mission that must not be sent: no items, a repeated point, a leg too long…"""

    field = "items"

    def __init__(self, problems: list[str]) -> None:
        super().__init__("; ".join(problems), problems=problems)


class MissionFileError(VesselsError):
    """A mission file that cannot be read, or holds items a Shoreside mission cannot."""

    field = "file"
