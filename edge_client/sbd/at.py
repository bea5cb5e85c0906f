"""The AT dialogue of an Iridium 9602/9603 SBD modem (RockBLOCK), without I/O.

Reference: Iridium's ISU AT Command Reference and the RockBLOCK AT command pages, as publicly
documented: ``+SBDWB`` (READY, message, 2-byte checksum, result 0–3), ``+SBDRB`` (2-byte length,
message, 2-byte checksum), ``+SBDIX[A]`` (six numbers), ``+CSQ`` (0–5 bars), ``SBDRING``.

Framing. Text answers are ``<CR><LF>text<CR><LF>`` lines, echoes end with a bare ``<CR>``:
:class:`SbdReader` splits on either and drops empty lines. The one binary answer, ``+SBDRB``'s
frame, cannot be split into lines; :meth:`SbdReader.frame` reads it and tells it from text by
its first byte: every ISU's MT length is under 2048 bytes, so a frame starts with a byte below
0x08, while text (an echo, ``SBDRING``, ``OK``, CR or LF) starts at 0x0A or above.

Checksums (both directions) are the low 16 bits of the sum of the message's bytes, sent high
byte first. Parsers raise only :class:`~.errors.SbdParseError`; the reader never raises.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .errors import SbdParseError
from .session_codes import MT_STATUS, WRITE_RESULTS, MoStatus, mo_status

MO_MAX = 340  # 9602/9603: the largest mobile-originated message
MT_MAX = 270  # 9602/9603: the largest mobile-terminated message
FRAME_LIMIT = 0x0800  # any ISU's MT length is below this (the 9523's is 1890)
MAX_LINE = 512  # the longest text answer is +SBDIX's (~40 bytes); longer is garbage
BAUDRATE = 19_200  # the RockBLOCK's and the 9602's default
RING_LINES = frozenset({"SBDRING", "+SBDRING"})  # the reference spells it without "+"
FINAL_LINES = frozenset({"OK", "ERROR"})
_SBDIX = re.compile(r"^\+SBDIXA?:\s*(\d{1,5}(?:\s*,\s*\d{1,5}){5})$", re.ASCII)
_CSQ = re.compile(r"^\+CSQF?:\s*(\d)$", re.ASCII)


def checksum(data: bytes) -> int:
    """The ISU's checksum: the low 16 bits of the byte sum."""
    return sum(data) & 0xFFFF


def with_checksum(data: bytes) -> bytes:
    """What follows ``READY`` after ``AT+SBDWB=<n>``: the message, then its checksum."""
    return bytes(data) + checksum(data).to_bytes(2, "big")


def encode_frame(payload: bytes) -> bytes:
    """``+SBDRB``'s answer: 2-byte length, the message, 2-byte checksum (for the simulator)."""
    if len(payload) >= FRAME_LIMIT:
        raise SbdParseError(f"a frame holds under {FRAME_LIMIT} bytes, not {len(payload)}")
    return len(payload).to_bytes(2, "big") + bytes(payload) + checksum(payload).to_bytes(2, "big")


def split_frame(buffer: bytes) -> tuple[bytes, int] | None:
    """(message, bytes used) of the ``+SBDRB`` frame at the start of ``buffer``; None while it
    is incomplete. A checksum that does not match raises SbdParseError."""
    if len(buffer) < 2:
        return None
    length = int.from_bytes(buffer[:2], "big")
    if length >= FRAME_LIMIT:
        raise SbdParseError(f"implausible frame length {length}", bytes(buffer[:2]))
    end = 2 + length + 2
    if len(buffer) < end:
        return None
    payload = bytes(buffer[2 : 2 + length])
    sent = int.from_bytes(buffer[2 + length : end], "big")
    if sent != checksum(payload):
        raise SbdParseError(f"frame checksum {sent:#06x} != {checksum(payload):#06x}")
    return payload, end


@dataclass(frozen=True)
class SbdixResult:
    """The six numbers of ``+SBDIX:`` (or ``+SBDIXA:``)."""

    mo_status: int
    momsn: int
    mt_status: int
    mtmsn: int
    mt_length: int
    mt_queued: int

    @property
    def mo(self) -> MoStatus:
        return mo_status(self.mo_status)

    @property
    def mt_received(self) -> bool:
        return self.mt_status == 1

    @property
    def mt_meaning(self) -> str:
        return MT_STATUS.get(self.mt_status, "unknown MT status")


def parse_sbdix(line: str) -> SbdixResult:
    """``+SBDIX: <MO status>, <MOMSN>, <MT status>, <MTMSN>, <MT length>, <MT queued>``."""
    match = _SBDIX.match(line.strip())
    if match is None:
        raise SbdParseError("not a +SBDIX answer", line)
    numbers = [int(field) for field in match.group(1).split(",")]
    mo, momsn, mt, mtmsn, length, queued = numbers
    if momsn > 0xFFFF or mtmsn > 0xFFFF or mt > 2 or length >= FRAME_LIMIT or mo > 0xFF:
        raise SbdParseError("+SBDIX field out of range", line)
    return SbdixResult(mo, momsn, mt, mtmsn, length, queued)


def parse_csq(line: str) -> int:
    """Signal bars 0–5 from ``+CSQ:<n>`` (or ``+CSQF:``)."""
    match = _CSQ.match(line.strip())
    if match is None or int(match.group(1)) > 5:
        raise SbdParseError("not a +CSQ answer", line)
    return int(match.group(1))


def parse_digit(line: str, allowed: range) -> int:
    """A one-number answer (``+SBDWB``'s 0–3, ``+SBDD``'s 0–1)."""
    text = line.strip()
    if not (text.isascii() and text.isdigit()) or int(text) not in allowed:
        raise SbdParseError(f"not a result in {allowed.start}..{allowed.stop - 1}", line)
    return int(text)


def write_meaning(code: int) -> str:
    return WRITE_RESULTS.get(code, "unknown write result")


def is_ring(line: str) -> bool:
    return line.strip().upper() in RING_LINES


def is_final(line: str) -> bool:
    return line.strip().upper() in FINAL_LINES


@dataclass(frozen=True)
class Frame:
    """A complete ``+SBDRB`` message, checksum verified."""

    payload: bytes


@dataclass(frozen=True)
class BadFrame:
    """Bytes where a frame was expected that do not make one (a checksum that fails)."""

    reason: str


class SbdReader:
    """Incremental reader of the modem's bytes (sans-I/O): :meth:`feed` any chunks, then take
    text with :meth:`line` or, while ``+SBDRB`` is answering, its frame with :meth:`frame`.
    The same bytes in any chunking give the same results."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> None:
        self._buf += data

    def clear(self) -> bytes:
        """Drop everything buffered (after a timeout); returns it for the log."""
        data = bytes(self._buf)
        self._buf.clear()
        return data

    @property
    def pending(self) -> int:
        return len(self._buf)

    def line(self) -> str | None:
        """The next non-empty text line, or None until one is complete. An over-long run
        without a line end comes out in pieces of ``MAX_LINE`` (garbage, for the log)."""
        buf = self._buf
        while buf:
            end = _line_end(buf)
            if end >= 0:
                raw = bytes(buf[:end])
                del buf[: end + 1]  # the line and its CR or LF (the other half drops as empty)
            elif len(buf) >= MAX_LINE:
                raw = bytes(buf[:MAX_LINE])
                del buf[:MAX_LINE]
            else:
                return None
            text = raw.decode("latin-1").strip()
            if text:
                return text
        return None

    def frame(self) -> Frame | BadFrame | str | None:
        """While ``+SBDRB`` answers: the frame, a text line met before it (its echo, a ring,
        ``ERROR``), a BadFrame (the bad bytes are dropped), or None until more bytes come."""
        buf = self._buf
        while buf[:1] in (b"\r", b"\n"):
            del buf[:1]
        if not buf:
            return None
        if buf[0] >= FRAME_LIMIT >> 8:  # text: see the module doc
            return self.line()
        try:
            split = split_frame(bytes(buf))
        except SbdParseError as exc:
            length = int.from_bytes(buf[:2], "big")
            del buf[: min(len(buf), 2 + length + 2)]
            return BadFrame(str(exc))
        if split is None:
            return None
        payload, used = split
        del buf[:used]
        return Frame(payload)


def _line_end(buf: bytearray) -> int:
    """Index of the first CR or LF in ``buf`` (within MAX_LINE), or -1."""
    ends = [i for i in (buf.find(b"\r", 0, MAX_LINE), buf.find(b"\n", 0, MAX_LINE)) if i >= 0]
    return min(ends) if ends else -1
