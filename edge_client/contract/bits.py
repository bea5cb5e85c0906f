"""Bit streams for the compact encodings: fixed-width fields and exponential-Golomb codes.

Why Exp-Golomb: a fix's deltas are mostly small (a boat moves a few metres between fixes, its
battery hardly at all) but now and then large; an order-k Exp-Golomb code spends ``2q + 1 + k``
bits on a value of about ``2**(q + k)``, so the common small values cost a few bits and a rare
large one costs only a few more, with no table to agree on. Signed values are zigzag-mapped
first (0, -1, 1, -2, … → 0, 1, 2, 3, …). Bits are written most significant first.

Pure and stdlib-only (the boat–shore contract). Reading past the end, or a code whose prefix
is longer than any value this format writes, raises BitsError: a payload that is not ours
stops there instead of decoding into nonsense.
"""

from __future__ import annotations

# The longest Exp-Golomb prefix (zeros) a reader accepts: values below 2**40 need fewer, and
# garbage of zeros is refused at once instead of being read as a huge number.
MAX_PREFIX = 40


class BitsError(ValueError):
    """The bits end early, or hold a code no writer of this format makes."""


def zigzag(n: int) -> int:
    return (n << 1) if n >= 0 else (-n << 1) - 1


def unzigzag(z: int) -> int:
    return (z >> 1) if not z & 1 else -((z + 1) >> 1)


class BitWriter:
    """Collects bits; ``bytes()`` pads the last byte with zeros."""

    __slots__ = ("_acc", "_n", "_out")

    def __init__(self) -> None:
        self._out = bytearray()
        self._acc = 0  # fewer than 8 pending bits, kept small so shifts stay cheap
        self._n = 0

    def write(self, value: int, width: int) -> None:
        """``value`` in exactly ``width`` bits (0 <= value < 2**width)."""
        if value < 0 or value >> width:
            raise ValueError(f"{value} does not fit in {width} bits")
        self._put(value, width)

    def _put(self, value: int, width: int) -> None:
        acc, n = (self._acc << width) | value, self._n + width
        while n >= 8:
            n -= 8
            self._out.append((acc >> n) & 0xFF)
        self._acc, self._n = acc & ((1 << n) - 1), n

    # The two codes call _put directly: their width fits the value by construction, and an
    # encode is mostly these calls (bench.compact).
    def exp_golomb(self, value: int, k: int) -> None:
        """A non-negative ``value`` as an order-``k`` Exp-Golomb code."""
        if value < 0:
            raise ValueError(f"{value} is negative: not an Exp-Golomb value")
        v = value + (1 << k)
        self._put(v, 2 * v.bit_length() - k - 1)  # bit_length - k - 1 leading zeros, then v

    def signed(self, value: int, k: int) -> None:
        v = ((value << 1) if value >= 0 else (-value << 1) - 1) + (1 << k)  # zigzag, then k
        self._put(v, 2 * v.bit_length() - k - 1)

    @property
    def bit_length(self) -> int:
        return len(self._out) * 8 + self._n

    def bytes(self) -> bytes:
        if self._n:
            return bytes(self._out) + bytes([(self._acc << (8 - self._n)) & 0xFF])
        return bytes(self._out)


class BitReader:
    """Reads what a BitWriter wrote from ``data``.

    The next bits wait in a small integer refilled REFILL_BYTES at a time: a read is a shift and
    a mask of a few machine words, and the zeros that open an Exp-Golomb code are counted
    with bit_length instead of bit by bit (a decode is mostly these two)."""

    __slots__ = ("_buf", "_data", "_have", "_next", "_remaining")

    REFILL_BYTES = 32

    def __init__(self, data: bytes) -> None:
        self._data = data
        self._next = 0  # the next byte of data to load
        self._buf = 0  # the loaded bits not read yet: exactly _have of them
        self._have = 0
        self._remaining = len(data) * 8

    def _fill(self, need: int) -> None:
        while self._have < need and self._next < len(self._data):
            chunk = self._data[self._next : self._next + self.REFILL_BYTES]
            self._next += len(chunk)
            self._buf = (self._buf << (8 * len(chunk))) | int.from_bytes(chunk, "big")
            self._have += 8 * len(chunk)

    def read(self, width: int) -> int:
        if width > self._remaining:
            raise BitsError("the payload ends in the middle of a field")
        if self._have < width:
            self._fill(width)
        have = self._have - width
        value = self._buf >> have
        self._buf &= (1 << have) - 1
        self._have = have
        self._remaining -= width
        return value

    def exp_golomb(self, k: int) -> int:
        if self._have <= MAX_PREFIX:
            self._fill(MAX_PREFIX + 1)
        buf = self._buf
        zeros = self._have - buf.bit_length()
        if zeros > MAX_PREFIX:
            raise BitsError("a number longer than any this format writes")
        if not buf:
            raise BitsError("the payload ends in the middle of a field")
        # read(), inlined: a decode is mostly this call.
        width = 2 * zeros + 1 + k
        if width > self._remaining:
            raise BitsError("the payload ends in the middle of a field")
        if self._have < width:
            self._fill(width)
            buf = self._buf
        have = self._have - width
        self._buf = buf & ((1 << have) - 1)
        self._have = have
        self._remaining -= width
        return (buf >> have) - (1 << k)

    def signed(self, k: int) -> int:
        z = self.exp_golomb(k)
        return (z >> 1) if not z & 1 else -((z + 1) >> 1)

    @property
    def remaining(self) -> int:
        return self._remaining
