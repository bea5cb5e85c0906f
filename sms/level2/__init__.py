"""Wave Glider "Level 2" payload serial protocol: codec, framing, payload machine, simulator.

Protocol facts and open questions: docs/level2.md. Layers (docs/architecture.md#layering):
``codec`` (frames, CRC, escaping), ``bodies`` (typed bodies, with ``enumeration`` and
``fields``, the coordinates, split from it), ``framing`` (incremental decoder), ``inner`` +
``inner_commands.toml`` (the inner command table), ``payload`` (the payload state machine),
``simulator`` (the C&C master side) are pure;
``runner`` is the only module that opens ports; ``cli`` is ``python -m sms.level2``.
Nothing here imports Django.
"""

from __future__ import annotations

from .codec import Address, Frame, MessageType, crc16_arc
from .errors import (
    BodyError,
    ChecksumError,
    CommandRefused,
    FrameError,
    Level2Error,
    LocalProtocolError,
    RemoteProtocolError,
    TableError,
)
from .framing import Decoder

__all__ = [
    "Address",
    "BodyError",
    "ChecksumError",
    "CommandRefused",
    "Decoder",
    "Frame",
    "FrameError",
    "Level2Error",
    "LocalProtocolError",
    "MessageType",
    "RemoteProtocolError",
    "TableError",
    "crc16_arc",
]
