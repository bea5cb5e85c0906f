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
        acc, n = (self._acc << width) | value, self._n + width
        while n >= 8:
            n -= 8
            self._out.append((acc >> n) & 0xFF)
        self._acc, self._n = acc & ((1 << n) - 1), n

    def exp_golomb(self, value: int, k: int) -> None:
        """A non-negative ``value`` as an order-``k`` Exp-Golomb code."""
        v = value + (1 << k)
        width = v.bit_length()
        self.write(v, 2 * width - k - 1)  # width - k - 1 leading zeros, then v

    def signed(self, value: int, k: int) -> None:
        self.exp_golomb(zigzag(value), k)

    @property
    def bit_length(self) -> int:
        return len(self._out) * 8 + self._n

    def bytes(self) -> bytes:
        if self._n:
            return bytes(self._out) + bytes([(self._acc << (8 - self._n)) & 0xFF])
        return bytes(self._out)


class BitReader:
    """Reads what a BitWriter wrote from ``data``."""

    __slots__ = ("_data", "_end", "_pos")

    def __init__(self, data: bytes) -> None:
        self._data = data
        self._pos = 0
        self._end = len(data) * 8

    def read(self, width: int) -> int:
        end = self._pos + width
        if end > self._end:
            raise BitsError("the payload ends in the middle of a field")
        value = self._peek(self._pos, width)
        self._pos = end
        return value

    def _peek(self, pos: int, width: int) -> int:
        if not width:
            return 0
        first, last = pos >> 3, (pos + width + 7) >> 3
        chunk = int.from_bytes(self._data[first:last], "big")
        return (chunk >> ((last << 3) - pos - width)) & ((1 << width) - 1)

    def exp_golomb(self, k: int) -> int:
        # One look at the next bits finds the prefix and, mostly, the whole code.
        pos = self._pos
        width = min(64, self._end - pos)
        window = self._peek(pos, width)
        zeros = width - window.bit_length()
        if zeros > MAX_PREFIX:
            raise BitsError("a number longer than any this format writes")
        if not window:
            raise BitsError("the payload ends in the middle of a field")
        size = 2 * zeros + 1 + k
        if size <= width:
            self._pos = pos + size
            v = (window >> (width - size)) & ((1 << size) - 1)
        else:
            self._pos = pos + zeros
            v = self.read(zeros + 1 + k)
        return v - (1 << k)

    def signed(self, k: int) -> int:
        z = self.exp_golomb(k)
        return (z >> 1) if not z & 1 else -((z + 1) >> 1)

    @property
    def remaining(self) -> int:
        return self._end - self._pos
