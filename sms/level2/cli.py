"""Command line: ``python -m sms.level2 decode | payload | cc`` (no Django needed).

References: docs/level2.md#the-library-smslevel2 (codec, payload, simulator duties); issue 4 §6.

* ``decode [FILE] [--hex] [--cfa]``: one line per frame found in a raw byte stream (hex text with
  ``--hex``; a logic-analyser capture with ``--cfa``), then good/bad/dropped counts.
* ``payload --port URL [--command "fhead 230" ...]``: run the payload state machine.
* ``cc --port URL [--period S] [--fault NAME ...]``: run the C&C simulator.

``--port pty`` creates a pseudo-terminal pair and prints the device for the other side to open.
"""

from __future__ import annotations

import argparse
import re
import signal
import sys
import threading
from collections.abc import Sequence
from typing import TextIO

import serial

from .bodies import ExtraInfo, summarize
from .cfa import read_cfa
from .codec import Address, peek_header, type_name
from .errors import ChecksumError, CommandRefused, FrameError, TableError
from .framing import Decoder
from .inner import InnerCommandTable
from .payload import MemoryCommandSource, PayloadConfig, PayloadMachine
from .runner import PayloadRunner, PtyPort, SerialLink, open_port
from .simulator import ACK_POLICIES, FAULTS, CcSimulator, RealClock, SimConfig

_NOT_HEX = re.compile(r"0x|[^0-9a-fA-F]")


def main(argv: Sequence[str] | None = None, out: TextIO | None = None) -> int:
    """Entry point; returns the process exit status."""
    out = out or sys.stdout
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args, out)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # e.g. `decode … | head`
        return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m sms.level2", description=__doc__.split("\n")[0]
    )
    sub = parser.add_subparsers(required=True)

    decode = sub.add_parser("decode", help="print the frames in a byte stream")
    decode.add_argument("file", nargs="?", default="-", help="file to read (default: stdin)")
    form = decode.add_mutually_exclusive_group()
    form.add_argument("--hex", action="store_true", help="input is hex text")
    form.add_argument("--cfa", action="store_true", help="input is a .cfa logic-analyser capture")
    decode.set_defaults(func=_decode)

    payload = sub.add_parser("payload", help="run the payload state machine on a port")
    payload.add_argument("--port", required=True, help="device, pyserial URL, or 'pty'")
    payload.add_argument("--command", action="append", default=[], help='e.g. "fhead 230"')
    payload.add_argument("--address", default="00/01", help="task/board in hex (default 00/01)")
    payload.add_argument("--period", type=int, default=20, help="declared poll period, s")
    payload.add_argument("--table", help="inner command table to use instead of the shipped one")
    payload.add_argument("--duration", type=float, help="stop after this many seconds")
    payload.set_defaults(func=_payload)

    cc = sub.add_parser("cc", help="run the C&C simulator on a port")
    cc.add_argument("--port", required=True, help="device, pyserial URL, or 'pty'")
    cc.add_argument("--period", type=float, help="poll period, s (default: the declared one)")
    cc.add_argument("--fault", action="append", default=[], choices=FAULTS, help="inject")
    cc.add_argument("--fault-rate", type=float, default=0.3, help="share of requests faulted")
    cc.add_argument("--ack-policy", choices=sorted(ACK_POLICIES), default="ack")
    cc.add_argument("--duration", type=float, default=float("inf"), help="seconds to run")
    cc.add_argument("--seed", type=int, default=0)
    cc.set_defaults(func=_cc)
    return parser


def _read_input(name: str) -> bytes:
    if name == "-":
        return sys.stdin.buffer.read()
    with open(name, "rb") as handle:
        return handle.read()


def _decode(args: argparse.Namespace, out: TextIO) -> int:
    data = _read_input(args.file)
    if args.hex:
        digits = _NOT_HEX.sub("", data.decode("ascii", "replace"))
        if len(digits) % 2:
            print("error: odd number of hex digits", file=out)
            return 2
        data = bytes.fromhex(digits)
    streams = [("", data)]
    if args.cfa:
        capture = read_cfa(data)
        streams = [("C&C->PAY ", capture.cc_to_payload), ("PAY->C&C ", capture.payload_to_cc)]
    good = bad = dropped = 0
    for label, stream in streams:
        decoder = Decoder()
        decoder.feed(stream)
        for item in decoder.frames():
            print(label + _describe(item), file=out)
        good += decoder.good_frames
        bad += decoder.bad_frames
        dropped += decoder.dropped_bytes
    print(f"summary: good={good} bad={bad} dropped_bytes={dropped}", file=out)
    return 0


def _describe(item: object) -> str:
    if isinstance(item, ChecksumError):
        header = peek_header(item.unescaped)
        if header is not None:
            length, dest, src, tid, word = header
            return f"{type_name(word & 0x7FFF)} {src}->{dest} tid=0x{tid:04X} L={length} crc=bad"
        return f"bad frame: {item} crc=bad"
    if isinstance(item, FrameError):
        return f"bad frame: {item} ({len(item.raw)} bytes)"
    return f"{summarize(item)} crc=ok"  # type: ignore[arg-type]


def _parse_address(text: str) -> Address:
    task, board = text.split("/")
    return Address(int(task, 16), int(board, 16))


def _payload(args: argparse.Namespace, out: TextIO) -> int:
    try:
        table = InnerCommandTable.load(args.table)
        source = MemoryCommandSource(table)
        for text in args.command:
            queued = source.add(text)
            print(f"queued {queued.ident}: {queued.command.text}", file=out)
    except (CommandRefused, TableError) as exc:
        print(f"refused: {exc}", file=out)
        return 2
    config = PayloadConfig(
        address=_parse_address(args.address),
        poll_period_s=args.period,
        flags=ExtraInfo.COMMAND_ACK | ExtraInfo.POWER,
    )
    machine = PayloadMachine(config, source=source)
    url = args.port
    factory = open_port
    if url == "pty":
        pty = PtyPort()
        print(f"pty: the C&C side opens {pty.name}", file=out)
        factory = lambda _url: pty  # noqa: E731 - the same pty on every (re)open
    runner = PayloadRunner(url, machine, trace=lambda line: print(line, file=out, flush=True))
    runner.port_factory = factory
    if args.duration is not None:
        timer = threading.Timer(args.duration, runner.stop)
        timer.daemon = True
        timer.start()
    # SIGTERM only sets the stop flag, so the results below are still printed.
    previous = signal.signal(signal.SIGTERM, lambda _sig, _frame: runner.stop())
    try:
        runner.run()
    finally:
        signal.signal(signal.SIGTERM, previous)
    for ident, result in source.results.items():
        print(f"result {ident}: code={result.code} ({result.meaning})", file=out)
    return 0


def _cc(args: argparse.Namespace, out: TextIO) -> int:
    port = open_port(args.port)
    if isinstance(port, PtyPort):
        print(f"pty: the payload side opens {port.name}", file=out, flush=True)
    config = SimConfig(
        period_s=args.period,
        faults=tuple(args.fault),
        fault_rate=args.fault_rate if args.fault else 0.0,
        ack_policy=ACK_POLICIES[args.ack_policy],
        seed=args.seed,
    )
    sim = CcSimulator(
        SerialLink(port),
        config,
        RealClock(),
        trace=lambda line: print(line, file=out, flush=True),
    )
    try:
        sim.run(args.duration)
    except (serial.SerialException, OSError) as exc:
        print(f"port {args.port} failed: {exc}", file=out)
        return 1
    finally:
        print(f"summary: {sim.stats.summary()}", file=out)
        port.close()
    return 1 if sim.stats.unexpected_replies or sim.stats.duplicate_mismatches else 0
