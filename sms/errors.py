"""The sms app's errors: one base, a person-readable message, optionally the field at fault.

Pure (no Django). Admin forms and management commands turn them into form errors and
command errors; the SMS path itself never raises them at a field user (it replies or logs).
"""

from __future__ import annotations


class SmsError(ValueError):
    """An SMS-side request that cannot be carried out; ``message`` says why, ``field`` where."""

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.field = field


class InvalidNumber(SmsError):
    """Text that is not a valid phone number (in E.164 or the default region's national form)."""

    def __init__(self, message: str) -> None:
        super().__init__(message, field="number")


class NumberNotFound(SmsError):
    """No authorised-number entry for this number."""

    def __init__(self, message: str) -> None:
        super().__init__(message, field="number")


class SmsRouteError(SmsError):
    """A shore command that cannot go to its vessel by SMS; ``message`` says why (the
    routing reports it and tries another link)."""


class NotSayable(SmsRouteError):
    """A command the glider's SMS language cannot carry in one SMS (no SMS word, too long)."""


class RouteNotConfigured(SmsRouteError):
    """Nothing to send it with or to: no SMS number on the vessel, no sender on the shore."""
