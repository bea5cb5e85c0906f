"""Incremental Level 2 frame decoder. Pure: bytes and times in, frames out; no clock, no port.

References (§ as in docs/level2.md#section-numbers-in-the-code):
* §4 framing and escaping, §16 "Decoding must be an incremental state machine fed arbitrary
  chunks": hunt for 0x7E, unescape as bytes arrive (a 0x7D may end a chunk), read L after two
  unescaped bytes, reject L < 12 or L > 558, collect L bytes, check residue 0; a raw 0x7E
  mid-frame aborts the frame; a bad escape aborts; drop a partial frame after an inter-byte
  timeout (0.5 s, well under the C&C's 2 s retry, §10);
* §2: the line carries junk (a 0.9 s burst of 0xFF in the capture) which is skipped and counted.
"""

from __future__ import annotations

from collections.abc import Iterator

from .codec import (
    CRC_SIZE,
    ESC,
    ESC_XOR,
    HEADER_SIZE,
    MAX_LENGTH,
    MIN_LENGTH,
    NO_ACK_BIT,
    SOF,
    TYPE_MASK,
    Frame,
    crc16_arc,
)
from .errors import ChecksumError, FrameError

INTERBYTE_TIMEOUT_S = 0.5  # §16: well under the C&C's ~2 s retry interval (§10)

_UNESCAPE = {0x5D: ESC, 0x5E: SOF}  # §4


class Decoder:
    """Feed arbitrary chunks with :meth:`feed`, then call :meth:`next_frame` until it returns None.

    ``next_frame`` returns a :class:`Frame`, returns ``None`` when more bytes are needed, or
    raises :class:`FrameError` / :class:`ChecksumError` *after* consuming the bad bytes, so the
    caller logs and calls it again. Counters: ``good_frames``, ``bad_frames``, ``timeouts`` and
    ``dropped_bytes`` (every received byte that did not end up in a good frame).

    Time is passed in (``feed(data, now)``), never read here: if more than ``interbyte_timeout``
    seconds pass between bytes, a frame still incomplete when the gap began is dropped.
    ``feed(b"", now)`` is a tick that lets a stale half frame expire without new bytes.
    """

    def __init__(self, interbyte_timeout: float = INTERBYTE_TIMEOUT_S) -> None:
        self.interbyte_timeout = interbyte_timeout
        self._buf = bytearray()
        # Bytes before this index arrived before an inter-byte gap longer than the timeout.
        self._stale = 0
        self._last_rx: float | None = None
        self.good_frames = 0
        self.bad_frames = 0
        self.timeouts = 0
        self.dropped_bytes = 0

    @property
    def buffered(self) -> int:
        """Bytes held: a partial frame waiting for the rest."""
        return len(self._buf)

    def feed(self, data: bytes, now: float | None = None) -> None:
        """Append received bytes; ``now`` (seconds, any monotonic origin) enables the timeout."""
        if now is not None:
            last = self._last_rx
            if last is not None and self._buf and now - last > self.interbyte_timeout:
                self._stale = len(self._buf)
            if data:
                self._last_rx = now
        self._buf += data

    def _consume(self, count: int, *, good: bool) -> None:
        del self._buf[:count]
        self._stale = max(0, self._stale - count)
        if good:
            self.good_frames += 1
        else:
            self.dropped_bytes += count

    def _reject(self, count: int, error: FrameError) -> FrameError:
        self._consume(count, good=False)
        self.bad_frames += 1
        return error

    def next_frame(self) -> Frame | None:
        """Return the next good frame, None if more bytes are needed, or raise (see class doc).

        1. Skip (and count) everything before a 0x7E.
        2. Unescape from there up to the next raw 0x7E, the stale mark or the end of the buffer.
        3. With two bytes, read L and reject it if out of range.
        4. With L bytes, check the CRC residue and build the frame.
        """
        buf = self._buf
        start = buf.find(SOF)
        if start < 0:
            self._consume(len(buf), good=False)
            return None
        if start:
            self._consume(start, good=False)
        limit = self._stale or len(buf)
        nxt = buf.find(SOF, 1, limit)
        end = nxt if nxt >= 0 else limit
        if buf.find(ESC, 1, end) < 0:
            # Fast path, as in every captured frame: nothing escaped, raw == unescaped.
            if end >= 3:
                length = buf[1] | buf[2] << 8
                if not MIN_LENGTH <= length <= MAX_LENGTH:
                    raise self._reject(end, FrameError(f"bad length {length}", bytes(buf[:end])))
                if end >= 1 + length:
                    return self._finish(bytes(buf[: 1 + length]), 1 + length)
        else:
            result = self._slow_unescape(end)
            if isinstance(result, tuple):
                return self._finish(*result)
        # Incomplete between here and `end`.
        if nxt >= 0:
            raise self._reject(end, FrameError("truncated frame: new 0x7E", bytes(buf[:end])))
        if self._stale:
            self.timeouts += 1
            stale = self._stale
            raise self._reject(stale, FrameError("inter-byte timeout", bytes(buf[:stale])))
        return None

    def _slow_unescape(self, end: int) -> tuple[bytes, int] | None:
        """Unescape buf[1:end] until L bytes are out; (unescaped frame, raw size) or None."""
        buf = self._buf
        out = bytearray((SOF,))
        need = 0
        i = 1
        while i < end:
            byte = buf[i]
            if byte == ESC:
                if i + 1 >= end:
                    return None  # a pending 0x7D at the end of a chunk (§16)
                partner = buf[i + 1]
                if partner not in _UNESCAPE:
                    raise self._reject(
                        i + 2, FrameError(f"bad escape 7D {partner:02X}", bytes(buf[: i + 2]))
                    )
                out.append(partner ^ ESC_XOR)
                i += 2
            else:
                out.append(byte)
                i += 1
            if not need and len(out) >= 3:
                need = out[1] | out[2] << 8
                if not MIN_LENGTH <= need <= MAX_LENGTH:
                    raise self._reject(i, FrameError(f"bad length {need}", bytes(buf[:i])))
            if need and len(out) == need + 1:
                return bytes(out), i
        return None

    def _finish(self, unescaped: bytes, raw_size: int) -> Frame:
        raw = bytes(self._buf[:raw_size])
        if crc16_arc(unescaped[1:]) != 0:
            raise self._reject(
                raw_size, ChecksumError("CRC-16/ARC residue is not zero", raw, unescaped)
            )
        self._consume(raw_size, good=True)
        word = unescaped[9] | unescaped[10] << 8
        return Frame(
            word & TYPE_MASK,
            unescaped[HEADER_SIZE:-CRC_SIZE],
            unescaped[7] | unescaped[8] << 8,
            unescaped[3],
            unescaped[4],
            unescaped[5],
            unescaped[6],
            bool(word & NO_ACK_BIT),
        )

    def frames(self) -> Iterator[Frame | FrameError]:
        """Everything decodable now: frames, and the errors raised for rejected bytes."""
        while True:
            try:
                frame = self.next_frame()
            except FrameError as error:
                yield error
                continue
            if frame is None:
                return
            yield frame


def decode_stream(data: bytes, interbyte_timeout: float = INTERBYTE_TIMEOUT_S) -> list[Frame]:
    """All good frames in a complete byte stream (errors skipped). For tests and tools."""
    decoder = Decoder(interbyte_timeout)
    decoder.feed(data)
    return [item for item in decoder.frames() if isinstance(item, Frame)]
