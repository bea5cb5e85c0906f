"""Errors of the Iridium SBD modem package. Pure: no serial, no I/O.

One base, :class:`SbdError`, carries ``permanent``: a temporary error (no satellite in view, a
modem that stopped answering, a port that went away) is worth trying again later; a permanent
one (a message too long, a modem locked or with its radio off) says why and is not retried.
"""

from __future__ import annotations


class SbdError(Exception):
    """Base of every error raised by ``edge_client.sbd``; ``permanent`` says whether to retry."""

    def __init__(self, message: str, permanent: bool = False) -> None:
        super().__init__(message)
        self.permanent = permanent

    @property
    def temporary(self) -> bool:
        return not self.permanent


class SbdParseError(SbdError):
    """A line or frame from the modem does not have the shape its parser expects.

    The only error the pure parsers in :mod:`edge_client.sbd.at` raise.
    """

    def __init__(self, message: str, data: str | bytes = "") -> None:
        super().__init__(f"{message}: {data!r}" if data else message)
        self.data = data


class MessageRefused(SbdError):
    """A mobile-originated message the modem cannot take (empty, or over 340 bytes).

    Raised before anything is written to the port.
    """

    def __init__(self, message: str) -> None:
        super().__init__(message, permanent=True)


class CommandError(SbdError):
    """The modem answered ``ERROR`` (or an unexpected result) to a command."""

    def __init__(self, command: str, answer: str) -> None:
        super().__init__(f"{command}: {answer}")
        self.command = command
        self.answer = answer


class WriteFailed(SbdError):
    """``AT+SBDWB`` answered 1 (write timeout), 2 (checksum mismatch) or 3 (bad size)."""

    def __init__(self, code: int, meaning: str) -> None:
        super().__init__(f"AT+SBDWB answered {code} ({meaning})", permanent=code == 3)
        self.code = code
        self.meaning = meaning


class SessionFailed(SbdError):
    """``AT+SBDIX`` failed ``attempts`` times; ``code`` is the last MO session status."""

    def __init__(self, code: int, meaning: str, attempts: int, permanent: bool) -> None:
        what = "permanent" if permanent else f"gave up after {attempts} attempts"
        super().__init__(f"SBD session failed: {code} ({meaning}); {what}", permanent)
        self.code = code
        self.meaning = meaning
        self.attempts = attempts


class SbdTimeout(SbdError):
    """No answer within the command's timeout: the modem is busy, asleep or gone."""


class PortError(SbdError):
    """The serial port could not be opened or failed; the next call reopens it."""
