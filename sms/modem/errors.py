"""Errors of the GSM modem package (docs/architecture.md). Pure: no serial, no Django.

One base, :class:`ModemError`, carries ``permanent``: a temporary error (network busy, a modem
that stopped answering, a port that went away) is worth retrying later; a permanent one (SIM PIN
needed, a number the network refuses, text the modem cannot take) says why and is not retried.
"""

from __future__ import annotations


class ModemError(Exception):
    """Base of every error raised by ``sms.modem``; ``permanent`` says whether to retry."""

    def __init__(self, message: str, permanent: bool = False) -> None:
        super().__init__(message)
        self.permanent = permanent

    @property
    def temporary(self) -> bool:
        return not self.permanent


class AtParseError(ModemError):
    """A line from the modem does not have the shape its parser expects (the peer's fault).

    The only error the pure parsers in :mod:`sms.modem.at` raise; the line reader itself never
    raises (it reports unexpected lines as ``Noise`` events).
    """

    def __init__(self, message: str, line: str = "") -> None:
        super().__init__(f"{message}: {line!r}" if line else message)
        self.line = line


class ModemUsageError(ModemError, ValueError):
    """We misused the package (a second command while one is in flight, a bad argument)."""

    def __init__(self, message: str) -> None:
        super().__init__(message, permanent=True)


class CommandError(ModemError):
    """The modem answered a command with ``ERROR``, ``+CMS ERROR: n`` or ``+CME ERROR: n``.

    ``code`` is the number (None for a bare ``ERROR`` or an unknown verbose text), ``meaning``
    the 3GPP TS 27.005 §3.2.5 / TS 27.007 §9.2 text, ``permanent`` from the same table.
    """

    def __init__(
        self, command: str, kind: str, code: int | None, meaning: str, permanent: bool
    ) -> None:
        number = f" {code}" if code is not None else ""
        super().__init__(f"{command}: {kind}{number} ({meaning})", permanent=permanent)
        self.command = command
        self.kind = kind
        self.code = code
        self.meaning = meaning


class ModemTimeout(ModemError):
    """No final result within the command's timeout: the modem is busy, restarting or gone."""


class ModemRestarted(ModemError):
    """The modem printed its power-up burst (``RDY`` …) while a command was in flight."""


class SendUnconfirmed(ModemTimeout):
    """The text and Ctrl-Z went out but no ``+CMGS`` answer came back in time.

    The SMS may or may not have left: retrying may deliver it twice. The caller decides.
    """


class PinRequired(ModemError):
    """``AT+CPIN?`` did not answer ``READY``: the SIM wants a PIN or PUK. Needs a person."""

    def __init__(self, state: str) -> None:
        super().__init__(f"SIM not ready: +CPIN: {state} (enter the PIN or remove it)", True)
        self.state = state


class UnsendableText(ModemError):
    """Text that cannot be typed after the ``> `` prompt in text mode (see ``driver.send``)."""

    def __init__(self, message: str) -> None:
        super().__init__(message, permanent=True)


class PortError(ModemError):
    """The serial port (or socket) could not be opened or failed; the driver reopens it."""
