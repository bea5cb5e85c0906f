"""Read the logic-analyser captures (.cfa) of real Level 2 traffic. Pure: bytes in, streams out.

Reference: tests/sms/level2/data/README.md (the captures): records are a channel
byte (0x09 payload→C&C, 0x0A C&C→payload), one data byte, a timestamp byte count n (4 or 5) and
an n-byte little-endian timestamp in 100 ns ticks; other record kinds can be skipped.

The other kinds' lengths are not documented, so this reader skips any byte that does not start a
data record. That cannot invent frames: every frame still has to pass the CRC, and on the two
public captures it yields exactly the 58 good frames and one bad one the page reports.
"""

from __future__ import annotations

from dataclasses import dataclass

PAYLOAD_TO_CC = 0x09  # Appendix B
CC_TO_PAYLOAD = 0x0A  # Appendix B
TIMESTAMP_SIZES = (4, 5)  # Appendix B
TICK_S = 100e-9  # Appendix B: 100 ns ticks (20 s poll period = 2.0×10⁸ ticks)


@dataclass(frozen=True)
class Capture:
    """Each direction's bytes in order, with the tick of every byte."""

    payload_to_cc: bytes
    cc_to_payload: bytes
    payload_ticks: tuple[int, ...]
    cc_ticks: tuple[int, ...]


def read_cfa(data: bytes) -> Capture:
    """Split a .cfa capture into its two byte streams (see the module docstring)."""
    streams: dict[int, bytearray] = {PAYLOAD_TO_CC: bytearray(), CC_TO_PAYLOAD: bytearray()}
    ticks: dict[int, list[int]] = {PAYLOAD_TO_CC: [], CC_TO_PAYLOAD: []}
    i = 0
    end = len(data)
    while i + 2 < end:
        channel = data[i]
        size = data[i + 2]
        if channel in streams and size in TIMESTAMP_SIZES and i + 3 + size <= end:
            streams[channel].append(data[i + 1])
            ticks[channel].append(int.from_bytes(data[i + 3 : i + 3 + size], "little"))
            i += 3 + size
        else:
            i += 1  # another record kind: skip a byte at a time until a data record starts
    return Capture(
        bytes(streams[PAYLOAD_TO_CC]),
        bytes(streams[CC_TO_PAYLOAD]),
        tuple(ticks[PAYLOAD_TO_CC]),
        tuple(ticks[CC_TO_PAYLOAD]),
    )
