"""Command line: ``python -m edge_client.sbd send FILE | receive | signal --port URL``.

* ``send FILE``: send the file's bytes (1 to 340) as one MO message; print the MOMSN and any
  MT message the session brought (as hex, and as text when it is printable).
* ``receive``: mailbox checks until the gateway's queue is empty (``--max`` at most); with
  ``--wait-ring S`` wait that long for an SBDRING first.
* ``signal``: the signal strength in bars (``AT+CSQ``).

Exit status: 0 done, 1 a temporary failure (try again later), 2 a permanent one or bad input.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from .driver import SbdConfig, SbdModem, SessionResult
from .errors import SbdError


def main(argv: Sequence[str] | None = None, out: TextIO | None = None) -> int:
    """Entry point; returns the process exit status."""
    out = out or sys.stdout
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING)
    config = SbdConfig(
        args.port,
        baudrate=args.baud,
        session_attempts=args.attempts,
        backoff_first_s=args.backoff,
        ring_alerts=True,
    )
    modem = SbdModem(config)
    try:
        return int(args.func(args, modem, out))
    except SbdError as exc:
        kind = "permanent" if exc.permanent else "temporary"
        print(f"error ({kind}): {exc}", file=out)
        return 2 if exc.permanent else 1
    except OSError as exc:
        print(f"error: {exc}", file=out)
        return 2
    except KeyboardInterrupt:
        return 130
    finally:
        modem.close()


def _parser() -> argparse.ArgumentParser:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--port", required=True, help="device, e.g. /dev/ttyUSB0, or pyserial URL")
    common.add_argument("--baud", type=int, default=19_200, help="default 19200 (RockBLOCK)")
    common.add_argument("--attempts", type=int, default=5, help="sessions per exchange")
    common.add_argument("--backoff", type=float, default=10.0, help="first wait after a failure")
    common.add_argument("-v", "--verbose", action="store_true", help="log the AT dialogue")
    parser = argparse.ArgumentParser(prog="python -m edge_client.sbd", description=__doc__)
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    sub = parser.add_subparsers(required=True)
    send = sub.add_parser("send", parents=[common], help="send a file as one MO message")
    send.add_argument("file", type=Path)
    send.set_defaults(func=_send)
    receive = sub.add_parser("receive", parents=[common], help="fetch waiting MT messages")
    receive.add_argument("--max", type=int, default=10, help="at most this many sessions")
    receive.add_argument("--wait-ring", type=float, metavar="S", help="wait for SBDRING first")
    receive.set_defaults(func=_receive)
    signal = sub.add_parser("signal", parents=[common], help="signal strength in bars")
    signal.set_defaults(func=_signal)
    return parser


def _send(args: argparse.Namespace, modem: SbdModem, out: TextIO) -> int:
    data = args.file.read_bytes()
    result = modem.exchange(data)
    print(f"sent {len(data)} bytes: momsn {result.momsn}", file=out)
    _print_mt(result, out)
    return 0


def _receive(args: argparse.Namespace, modem: SbdModem, out: TextIO) -> int:
    if args.wait_ring is not None:
        rang = modem.wait_for_ring(args.wait_ring)
        print("ring" if rang else "no ring", file=out, flush=True)
    for _session in range(max(1, args.max)):
        result = modem.exchange(None)
        _print_mt(result, out)
        if result.mt is None:
            print(f"no message waiting (momsn {result.momsn})", file=out)
        if result.mt_queued == 0:
            break
    return 0


def _signal(_args: argparse.Namespace, modem: SbdModem, out: TextIO) -> int:
    print(f"signal: {modem.signal()} bars", file=out)
    return 0


def _print_mt(result: SessionResult, out: TextIO) -> None:
    if result.mt is None:
        if result.mt_lost:
            print("an MT message came but could not be read", file=out)
        return
    text = result.mt.decode("utf-8", "replace")
    shown = f" {text!r}" if text.isprintable() else ""
    print(
        f"MT mtmsn {result.mtmsn}, {len(result.mt)} bytes: {result.mt.hex()}{shown} "
        f"({result.mt_queued} more queued)",
        file=out,
        flush=True,
    )
