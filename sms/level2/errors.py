"""Errors of the Level 2 library (docs/architecture.md#rules-that-hold-everywhere).

References: §4 (framing) and §16 (decoder rules) of docs/level2.md.

The split follows wsproto/h11: ``LocalProtocolError`` means *we* were misused (a field out of
range, a command the table refuses); ``RemoteProtocolError`` means *the peer* sent garbage (bad
checksum, bad length, bad escape, a body too short for its type). Decoders raise only these; the
serial loop catches them, logs them and carries on.
"""

from __future__ import annotations


class Level2Error(Exception):
    """Base class for every error raised by ``sms.level2``."""


class LocalProtocolError(Level2Error, ValueError):
    """We asked the library for something the protocol cannot express."""


class RemoteProtocolError(Level2Error):
    """The bytes from the peer do not make a valid frame or body."""


class FrameError(RemoteProtocolError):
    """A frame was malformed on the wire (length, escape, truncation, timeout).

    ``raw`` holds the offending wire bytes when the decoder had them, for logs and the
    ``decode`` command's report.
    """

    def __init__(self, message: str, raw: bytes = b"") -> None:
        super().__init__(message)
        self.raw = raw


class ChecksumError(FrameError):
    """The CRC-16/ARC residue of a complete frame was not zero (§3, docs/level2.md).

    ``unescaped`` is the whole frame after unescaping (SOF included) so callers can still
    print its header.
    """

    def __init__(self, message: str, raw: bytes = b"", unescaped: bytes = b"") -> None:
        super().__init__(message, raw)
        self.unescaped = unescaped


class BodyError(RemoteProtocolError):
    """A frame was valid but its body does not fit the layout of its message type."""


class TableError(LocalProtocolError):
    """The inner command data file is inconsistent (a mistake by whoever edited it)."""


class CommandRefused(LocalProtocolError):
    """The inner command table will not encode this command; ``reason`` says why."""

    def __init__(self, word: str, reason: str) -> None:
        super().__init__(f"{word}: {reason}")
        self.word = word
        self.reason = reason
