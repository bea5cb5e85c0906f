"""Command line: ``python -m sms.modem sim | listen | send`` (no Django needed).

References: docs/sms.md, 'The GSM modem'; issue 10 items 4 and 5.

* ``sim --port pty|tcp:PORT``: run the modem simulator; prints where the driver connects. Each
  line typed on stdin, ``<number> <text>`` (``+61400000001 #FHEAD 230``), arrives as an SMS;
  ``!reset``, ``!deaf S``, ``!garbage``, ``!delay S``, ``!send-error N``, ``!read-error N``,
  ``!urc on|off`` switch faults. Every SMS the driver sends is printed.
* ``listen --port URL [--delete]``: print stored and arriving messages (delete after printing
  only with ``--delete``: printing is this tool's "store").
* ``send --port URL --to NUMBER --text TEXT``: send one SMS, print its reference.
"""

from __future__ import annotations

import argparse
import logging
import select
import signal
import sys
import threading
import time
from collections.abc import Sequence
from typing import TextIO

from .at import ReceivedSms
from .driver import Modem, ModemConfig, receive_all
from .errors import ModemError
from .simulator import ModemServer, SimulatedModem


def main(argv: Sequence[str] | None = None, out: TextIO | None = None) -> int:
    """Entry point; returns the process exit status."""
    out = out or sys.stdout
    args = _parser().parse_args(argv)
    logging.basicConfig(level=logging.DEBUG if args.verbose else logging.WARNING)
    stop = threading.Event()
    previous = signal.signal(signal.SIGTERM, lambda _sig, _frame: stop.set())
    try:
        return args.func(args, out, stop)
    except KeyboardInterrupt:
        return 130
    finally:
        signal.signal(signal.SIGTERM, previous)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python -m sms.modem", description=__doc__.split("\n")[0])
    parser.add_argument("-v", "--verbose", action="store_true", help="log the AT dialogue")
    sub = parser.add_subparsers(required=True)

    sim = sub.add_parser("sim", help="run the modem simulator")
    sim.add_argument("--port", default="pty", help="'pty' or 'tcp:PORT' (0: any free port)")
    sim.add_argument("--capacity", type=int, default=20, help="SIM store size")
    sim.add_argument("--delay", type=float, default=0.0, help="answer every command this late")
    sim.add_argument("--garbage", action="store_true", help="a junk line before every answer")
    sim.add_argument("--urc-mid-reply", action="store_true", help="URCs inside answers")
    sim.add_argument("--duration", type=float, help="stop after this many seconds")
    sim.set_defaults(func=_sim)

    listen = sub.add_parser("listen", help="print stored and arriving SMS")
    listen.add_argument("--port", required=True, help="device, socket://host:port, pyserial URL")
    listen.add_argument("--delete", action="store_true", help="delete each message once printed")
    listen.add_argument("--storage", default="SM", help='message store (default "SM")')
    listen.add_argument("--duration", type=float, help="stop after this many seconds")
    listen.set_defaults(func=_listen)

    send = sub.add_parser("send", help="send one SMS")
    send.add_argument("--port", required=True, help="device, socket://host:port, pyserial URL")
    send.add_argument("--to", required=True, help="number, e.g. +61400000001")
    send.add_argument("--text", required=True)
    send.set_defaults(func=_send)
    return parser


def _deadline(duration: float | None) -> float:
    return time.monotonic() + duration if duration is not None else float("inf")


def _sim(args: argparse.Namespace, out: TextIO, stop: threading.Event) -> int:
    modem = SimulatedModem(capacity=args.capacity)
    modem.faults.delay_s = args.delay
    modem.faults.garbage = args.garbage
    modem.faults.urc_mid_reply = args.urc_mid_reply
    server = ModemServer(modem, args.port).start()
    kind = "pty" if args.port == "pty" else "tcp"
    print(f"{kind}: the driver opens {server.url}", file=out, flush=True)
    deadline = _deadline(args.duration)
    reported = 0
    stdin_open = True
    try:
        while not stop.is_set() and time.monotonic() < deadline:
            if stdin_open and select.select([sys.stdin], [], [], 0.1)[0]:
                line = sys.stdin.readline()
                if not line:
                    stdin_open = False
                elif line.strip():
                    print(_sim_input(modem, line.strip()), file=out, flush=True)
            elif not stdin_open:
                time.sleep(0.1)
            for sms in modem.sent[reported:]:
                print(f"sent to {sms.number} (ref {sms.reference}): {sms.text}", file=out)
                reported += 1
            out.flush()
    finally:
        server.stop()
    print(f"summary: stored={len(modem.store)} sent={len(modem.sent)}", file=out)
    return 0


def _sim_input(modem: SimulatedModem, line: str) -> str:
    """One line from the operator: ``<number> <text>`` or a ``!fault``."""
    word, _space, rest = line.partition(" ")
    try:
        if word == "!reset":
            modem.reset(float(rest or 0))
        elif word == "!deaf":
            modem.go_deaf(float(rest or 5))
        elif word == "!garbage":
            modem.garbage()
        elif word == "!delay":
            modem.faults.delay_s = float(rest or 0)
        elif word == "!send-error":
            modem.faults.send_error = int(rest) if rest else None
        elif word == "!read-error":
            modem.faults.read_error = int(rest) if rest else None
        elif word == "!urc":
            modem.faults.urc_mid_reply = rest.strip() == "on"
        elif word.startswith("!"):
            return f"unknown: {word}"
        else:
            if not rest:
                return "type: <number> <text>"
            index = modem.inject(word, rest)
            return f"stored at {index}" if index is not None else "store full: rejected"
    except ValueError as exc:
        return f"bad value: {exc}"
    return f"ok: {line}"


def _describe(sms: ReceivedSms) -> str:
    when = sms.timestamp.isoformat() if sms.timestamp else "?"
    return f"[{sms.index}] {sms.number} {when} {sms.status}: {sms.text}"


def _listen(args: argparse.Namespace, out: TextIO, stop: threading.Event) -> int:
    modem = Modem(ModemConfig(args.port, storage=args.storage))
    deadline = _deadline(args.duration)
    try:
        modem.open()
        if not args.delete:
            for sms in modem.stored_messages():
                print(_describe(sms), file=out, flush=True)
        while not stop.is_set() and time.monotonic() < deadline:
            events = modem.poll_events(min(1.0, max(0.0, deadline - time.monotonic())))
            if args.delete:
                receive_all(modem, lambda sms: print(_describe(sms), file=out, flush=True), events)
                continue
            for index in events.indices:
                sms = modem.read(index)
                if sms is not None:
                    print(_describe(sms), file=out, flush=True)
    except ModemError as exc:
        print(f"error: {exc}", file=out)
        return 2 if exc.permanent else 1
    finally:
        modem.close()
    return 0


def _send(args: argparse.Namespace, out: TextIO, _stop: threading.Event) -> int:
    modem = Modem(ModemConfig(args.port))
    try:
        modem.open()
        reference = modem.send(args.to, args.text)
    except ModemError as exc:
        kind = "permanent" if exc.permanent else "temporary"
        print(f"error ({kind}): {exc}", file=out)
        return 2 if exc.permanent else 1
    finally:
        modem.close()
    print(f"sent: reference {reference}", file=out)
    return 0
