"""Level 2 benchmark: codec throughput and payload reply latency, each next to an in-run baseline.

Run: ``python -m bench.level2`` (prints figures; asserts nothing).

* Codec, status-reply-sized frames (31 bytes: docs/level2.md): encode with ``bytes(Frame)`` and
  decode through the incremental :class:`Decoder`, against a baseline of plain ``struct`` work on
  pre-split frames (pack of the fields; unpack of the header) with no CRC, escaping or framing.
* Reply latency through the serial runner over a pseudo-terminal pair: the time from the last
  byte of a status request written to the first byte of the answer readable (the real PIB answered
  4–17 ms after the *first* byte, §2). The runner is ``python -m sms.level2 payload`` in its own
  process, as deployed; the baseline is a process that answers every read with a canned reply
  through the same pyserial calls, without decoding.
"""

from __future__ import annotations

import argparse
import os
import select
import statistics
import struct
import subprocess
import sys
import time
from collections.abc import Callable, Sequence

from sms.level2.bodies import StatusBlock, StatusReply, StatusRequest
from sms.level2.codec import CC_MAIN, Address, Frame, MessageType
from sms.level2.framing import Decoder
from sms.level2.runner import PtyPort

PAYLOAD = Address(0x00, 0x01)
CODEC_FRAMES = 50_000
LATENCY_SAMPLES = 2_000
WARMUP = 50
CODEC_TARGET = 20_000  # issue 4: ≥ 20,000 frames/s each way
MEDIAN_TARGET_MS = 5.0  # issue 4
P99_TARGET_MS = 20.0  # issue 4
REPLY_SIZE = 31  # §7: status reply, unescaped with SOF
_HEADER = struct.Struct("<BHBBBBHH")


def status_reply(tid: int) -> Frame:
    body = bytes(StatusReply(StatusBlock(humidity_temp_c=21, humidity_pct=35, pressure_kpa=100)))
    return Frame.make(MessageType.ACK, body, tid=tid, dest=CC_MAIN, src=PAYLOAD)


def rate(count: int, work: Callable[[], object]) -> float:
    start = time.perf_counter()
    work()
    return count / (time.perf_counter() - start)


def bench_codec(count: int) -> list[tuple[str, float, float]]:
    """(label, frames/s, baseline frames/s) for encode and decode."""
    # tids 0..count-1 include values that need escaping, as real traffic does now and then
    frames = [status_reply(tid & 0xFFFF) for tid in range(count)]
    wires = [bytes(f) for f in frames]
    stream = b"".join(wires)
    fields = [
        (0x7E, 30, f.dest_task, f.dest_board, f.src_task, f.src_board, f.tid, f.type_word)
        for f in frames
    ]
    pre_split = [w[:11] for w in wires]

    def encode() -> None:
        for frame in frames:
            bytes(frame)

    def encode_baseline() -> None:
        pack = _HEADER.pack
        for row, frame in zip(fields, frames, strict=True):
            pack(*row) + frame.body

    def decode() -> None:
        decoder = Decoder()
        decoder.feed(stream)
        got = 0
        while decoder.next_frame() is not None:
            got += 1
        assert got == count

    def decode_baseline() -> None:
        unpack = _HEADER.unpack
        for header in pre_split:
            unpack(header)

    return [
        ("encode", rate(count, encode), rate(count, encode_baseline)),
        ("decode", rate(count, decode), rate(count, decode_baseline)),
    ]


def _wait_readable(fd: int, timeout: float) -> bool:
    return bool(select.select([fd], [], [], timeout)[0])


def measure_latency(command: Sequence[str], samples: int) -> list[float]:
    """Write status requests to a pty whose other end ``command`` serves; seconds per reply."""
    pty = PtyPort(timeout=1.0)
    proc = subprocess.Popen(
        [*command, pty.name], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    fd = pty.fileno()
    try:
        latencies = []
        tid = 0x100
        request_body = bytes(StatusRequest())
        deadline = time.monotonic() + 20
        for i in range(samples + WARMUP):
            tid = (tid + 1) & 0xFFFF
            wire = bytes(
                Frame.make(
                    MessageType.REQUEST_STATUS, request_body, tid=tid, dest=PAYLOAD, src=CC_MAIN
                )
            )
            pty.write(wire)
            sent = time.perf_counter()  # the last byte has been handed to the line
            if not _wait_readable(fd, 2.0):
                if i < WARMUP and time.monotonic() < deadline:
                    continue  # the server may still be starting
                raise RuntimeError(f"no answer from {command[-1]} within 2 s")
            answered = time.perf_counter()
            received = b""
            while len(received) < REPLY_SIZE and _wait_readable(fd, 1.0):
                received += os.read(fd, 4096)
            if i >= WARMUP:
                latencies.append(answered - sent)
        return latencies
    finally:
        proc.terminate()
        proc.wait(5)
        pty.close()


def echo_baseline(device: str) -> None:
    """Answer every read with a canned 31-byte reply, with the runner's pyserial calls."""
    import serial

    reply = bytes(status_reply(0))
    port = serial.serial_for_url(device, baudrate=115_200, timeout=0.05)
    while True:
        data = port.read(1)
        if data:
            waiting = port.in_waiting
            if waiting:
                port.read(waiting)
            port.write(reply)


def percentile(values: list[float], fraction: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=CODEC_FRAMES)
    parser.add_argument("--samples", type=int, default=LATENCY_SAMPLES)
    parser.add_argument("--echo-baseline", metavar="DEVICE", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.echo_baseline:
        echo_baseline(args.echo_baseline)
        return 0

    print(f"Level 2 codec, status-reply frames ({REPLY_SIZE} bytes), {args.frames} frames")
    for label, ours, base in bench_codec(args.frames):
        print(
            f"  {label}: {ours:>10,.0f} frames/s   baseline struct-only: {base:>11,.0f} frames/s"
            f"   (target >= {CODEC_TARGET:,})"
        )

    python = [sys.executable]
    runner = [*python, "-m", "sms.level2", "payload", "--port"]
    baseline = [*python, "-m", "bench.level2", "--echo-baseline"]
    print(f"Reply latency over a pty, last request byte -> first reply byte, {args.samples} polls")
    for label, command in (("runner", runner), ("baseline canned echo", baseline)):
        values = measure_latency(command, args.samples)
        med = statistics.median(values) * 1e3
        p99 = percentile(values, 0.99) * 1e3
        print(f"  {label}: median {med:.3f} ms   p99 {p99:.3f} ms   max {max(values) * 1e3:.3f} ms")
    print(f"  targets: median <= {MEDIAN_TARGET_MS} ms, p99 <= {P99_TARGET_MS} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
