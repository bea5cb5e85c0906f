"""Iridium SBD modem (9602/9603, RockBLOCK): the AT dialogue, a driver and a simulator.

Layers: ``at`` (line reader, frame and answer parsers), ``session_codes`` (what the session
results mean, whether to retry) and ``errors`` are pure; ``driver`` is the only module that
opens ports (pyserial); ``simulator`` is a modem on a pty for tests and demos
(``python -m edge_client.sbd.simulator``); ``cli`` is ``python -m edge_client.sbd``.

The API other code calls: ``SbdModem(port_url).exchange(mo: bytes | None) -> SessionResult``
(``mo_sent``, ``momsn``, ``mt``, ``mt_queued``), :meth:`SbdModem.wait_for_ring` and
:meth:`SbdModem.signal`. Stdlib and pyserial only: no Django, no server code.
"""

from __future__ import annotations

from .at import MO_MAX, MT_MAX, SbdixResult
from .driver import SbdConfig, SbdModem, SessionResult
from .errors import (
    CommandError,
    MessageRefused,
    PortError,
    SbdError,
    SbdParseError,
    SbdTimeout,
    SessionFailed,
    WriteFailed,
)
from .session_codes import MoStatus, Retry, mo_status

__all__ = [
    "MO_MAX",
    "MT_MAX",
    "CommandError",
    "MessageRefused",
    "MoStatus",
    "PortError",
    "Retry",
    "SbdConfig",
    "SbdError",
    "SbdModem",
    "SbdParseError",
    "SbdTimeout",
    "SbdixResult",
    "SessionFailed",
    "SessionResult",
    "WriteFailed",
    "mo_status",
]
