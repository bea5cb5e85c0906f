"""A simulated Iridium 9602/9603 (RockBLOCK) for tests and demos, served on a pseudo-terminal.

:class:`SimulatedSbdModem` is the modem and does no I/O: bytes in (:meth:`receive`), bytes out
(:meth:`take_output`, each chunk with the time it is due, so a slow session needs no sleeping
thread). It echoes until ``ATE0``, keeps the MO and MT buffers as the ISU does (a session
does not clear the MO buffer; it empties the MT buffer first), checks ``AT+SBDWB``'s checksum,
counts the MOMSN up on every successful session, and runs ``AT+SBDIX[A]`` against a network
the test side controls: ``network`` on or off (off: status 32), ``fail_codes`` (the statuses of
the next sessions), MT messages queued with :meth:`queue_mt` (an ``SBDRING`` when ring alerts
are on), and the sky's ``signal`` for ``AT+CSQ``. :class:`Faults` adds slow answers, garbage
lines, a corrupted MO byte (answered 2), lost MO bytes (answered 1 after the write timeout,
with no OK, as the ISU does), a corrupted MT frame, and a deaf modem.

:class:`SbdModemServer` serves one on a pty. ``python -m edge_client.sbd.simulator`` runs one and
prints the pty's path on its first line; lines on stdin drive it (``mt TEXT``, ``mthex HEX``,
``network on|off``, ``fail N``, ``signal N``, ``garbage``, ``deaf S``).
"""

from __future__ import annotations

import argparse
import os
import random
import re
import select
import sys
import threading
import time
import tty
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TextIO

from .at import MO_MAX, MT_MAX, checksum, encode_frame

WRITE_TIMEOUT_S = 60.0  # the ISU's: too few bytes after READY within this answer 1
MOMSN_WRAP = 0x10000


@dataclass(frozen=True)
class MoMessage:
    """An MO message the gateway received, with the MOMSN of its session."""

    momsn: int
    data: bytes


@dataclass
class Faults:
    """Misbehaviour, switched at any time (tests hold a reference)."""

    delay_s: float = 0.0  # every answer comes this late
    session_delay_s: float = 0.0  # and +SBDIX this much later again (the satellite pass)
    garbage: bool = False  # a junk line before every answer
    corrupt_write: bool = False  # the next AT+SBDWB message arrives with one byte flipped
    corrupt_frame: bool = False  # the next AT+SBDRB frame goes out with a wrong checksum
    lose_write_bytes: int = 0  # bytes of the next AT+SBDWB message lost on the line (→ 1)


@dataclass
class SimulatedSbdModem:
    """The ISU's state and AT interpreter. Thread-safe: tests call it while a server runs."""

    signal: int = 4  # bars, 0–5
    network: bool = True
    seed: int = 0
    write_timeout_s: float = WRITE_TIMEOUT_S
    clock: Callable[[], float] = time.monotonic
    faults: Faults = field(default_factory=Faults)

    def __post_init__(self) -> None:
        self.fail_codes: list[int] = []  # MO statuses of the next sessions, first first
        self.mt_queue: list[bytes] = []  # at the gateway
        # Every successful session's MO message, empty for a mailbox check (the gateway
        # delivers, and the provider bills, a blank one then).
        self.received: list[MoMessage] = []
        self.commands: list[str] = []
        self.momsn = 0
        self.mtmsn = 0
        self.mo_buffer: bytes | None = None
        self.mt_buffer: bytes | None = None
        self.ring_alerts = False  # the RockBLOCK's default: AT+SBDMTA=1 turns them on
        self.ring_flag = False  # a ring came and no mailbox check has answered it
        self.echo = True
        self._rng = random.Random(self.seed)
        self._lock = threading.RLock()
        self._out: list[tuple[float, bytes]] = []
        self._last_due = 0.0
        self._line = bytearray()
        self._binary: bytearray | None = None  # AT+SBDWB: the message and checksum coming
        self._binary_size = 0
        self._binary_since = 0.0
        self._deaf_until = 0.0

    # -- the outside world ----------------------------------------------------------------------

    @property
    def delivered(self) -> list[bytes]:
        """The non-empty MO messages the gateway received, in order."""
        with self._lock:
            return [message.data for message in self.received if message.data]

    def queue_mt(self, data: bytes, ring: bool = True) -> None:
        """An MT message reaches the gateway; with ``ring`` the gateway sends a ring alert."""
        with self._lock:
            self.mt_queue.append(bytes(data))
            if ring:
                self.ring_flag = True
                if self.ring_alerts:
                    self._out.append((self.clock(), b"SBDRING\r\n"))

    def garbage(self, size: int = 24) -> None:
        """Junk on the line now (no CR or LF in it), as a noisy cable would."""
        with self._lock:
            self._out.append((self.clock(), self._junk(size) + b"\r\n"))

    def go_deaf(self, seconds: float) -> None:
        """Stop answering (and drop input) for ``seconds``."""
        with self._lock:
            self._deaf_until = self.clock() + seconds

    def take_output(self) -> bytes:
        """Bytes due now, in the order they were queued."""
        with self._lock:
            now = self.clock()
            if now < self._deaf_until:
                return b""
            if self._binary is not None and now - self._binary_since > self.write_timeout_s:
                self._binary = None
                self._emit(b"\r\n1\r\n")  # the ISU's quirk: no OK after 1
            ready = b"".join(data for due, data in self._out if due <= now)
            self._out = [(due, data) for due, data in self._out if due > now]
            return ready

    def receive(self, data: bytes) -> None:
        """Bytes from the driver."""
        with self._lock:
            if self.clock() < self._deaf_until:
                return
            for byte in data:
                self._byte(byte)

    # -- the interpreter ------------------------------------------------------------------------

    def _byte(self, byte: int) -> None:
        if self._binary is not None:
            if self.faults.lose_write_bytes > 0:
                self.faults.lose_write_bytes -= 1
                return
            self._binary.append(byte)
            if len(self._binary) == self._binary_size + 2:
                self._finish_write(bytes(self._binary))
            return
        if self.echo:
            self._emit(bytes((byte,)), delay=False)
        if byte == 0x0D:
            line = self._line.decode("latin-1").strip()
            self._line.clear()
            if line:
                self._command(line)
        elif byte != 0x0A:
            self._line.append(byte)

    def _command(self, line: str) -> None:
        self.commands.append(line)
        upper = line.upper()
        if not upper.startswith("AT"):
            self._answer([], "ERROR")
            return
        body = upper[2:]
        simple: dict[str, Callable[[], None]] = {
            "": lambda: self._answer([], "OK"),
            "E0": lambda: self._set_echo(False),
            "E1": lambda: self._set_echo(True),
            "&K0": lambda: self._answer([], "OK"),
            "&K3": lambda: self._answer([], "OK"),
            "&D0": lambda: self._answer([], "OK"),
            "+CSQ": lambda: self._answer([f"+CSQ:{self.signal}"], "OK"),
            "+CSQF": lambda: self._answer([f"+CSQF:{self.signal}"], "OK"),
            "+SBDMTA?": lambda: self._answer([f"+SBDMTA:{int(self.ring_alerts)}"], "OK"),
            "+SBDIX": lambda: self._session(answer=False),
            "+SBDIXA": lambda: self._session(answer=True),
            "+SBDRB": self._read_binary,
            "+SBDS": self._status,
            "+SBDC": self._clear_momsn,
        }
        if body in simple:
            simple[body]()
            return
        patterns: list[tuple[str, Callable[[re.Match[str]], None]]] = [
            (r"\+SBDMTA=([01])", self._set_alerts),
            (r"\+SBDWB=(\d{1,5})", self._write_binary),
            (r"\+SBDWT=(.*)", self._write_text),
            (r"\+SBDD([012])", self._clear),
        ]
        for pattern, action in patterns:
            match = re.fullmatch(pattern, line[2:], re.IGNORECASE)
            if match:
                action(match)
                return
        self._answer([], "ERROR")

    def _set_echo(self, on: bool) -> None:
        self.echo = on
        self._answer([], "OK")

    def _set_alerts(self, match: re.Match[str]) -> None:
        self.ring_alerts = match.group(1) == "1"
        self._answer([], "OK")

    def _write_binary(self, match: re.Match[str]) -> None:
        size = int(match.group(1))
        if not 1 <= size <= MO_MAX:
            self._answer(["3"], "OK")  # a size it cannot take: no READY
            return
        self._binary = bytearray()
        self._binary_size = size
        self._binary_since = self.clock()
        self._emit(b"\r\nREADY\r\n")

    def _finish_write(self, data: bytes) -> None:
        self._binary = None
        message, sent = data[:-2], int.from_bytes(data[-2:], "big")
        if self.faults.corrupt_write:
            self.faults.corrupt_write = False
            message = bytes([message[0] ^ 0x55]) + message[1:]
        if checksum(message) != sent:
            self._answer(["2"], "OK")
            return
        self.mo_buffer = message
        self._answer(["0"], "OK")

    def _write_text(self, match: re.Match[str]) -> None:
        text = match.group(1).encode("latin-1")
        if len(text) > MO_MAX:
            self._answer([], "ERROR")
            return
        self.mo_buffer = text or None
        self._answer([], "OK")

    def _clear(self, match: re.Match[str]) -> None:
        kind = int(match.group(1))
        if kind in (0, 2):
            self.mo_buffer = None
        if kind in (1, 2):
            self.mt_buffer = None
        self._answer(["0"], "OK")

    def _clear_momsn(self) -> None:
        self.momsn = 0
        self._answer(["0"], "OK")

    def _status(self) -> None:
        mo, mt = int(self.mo_buffer is not None), int(self.mt_buffer is not None)
        mtmsn = self.mtmsn if self.mt_buffer is not None else -1
        self._answer([f"+SBDS: {mo}, {self.momsn}, {mt}, {mtmsn}"], "OK")

    def _session(self, answer: bool) -> None:
        """One SBD session: the MT buffer is emptied first, the MO buffer is kept."""
        self.mt_buffer = None
        name = "+SBDIXA" if answer else "+SBDIX"
        if self.fail_codes:
            code = self.fail_codes.pop(0)
        elif not self.network or self.signal == 0:
            code = 32
        else:
            code = 0
        if code > 4:
            line = f"{name}: {code}, {self.momsn}, 2, {self.mtmsn}, 0, {len(self.mt_queue)}"
            self._answer([line], "OK", extra_delay=self.faults.session_delay_s)
            return
        momsn = self.momsn
        self.momsn = (self.momsn + 1) % MOMSN_WRAP
        self.received.append(MoMessage(momsn, self.mo_buffer or b""))
        mt_status, length = 0, 0
        if self.mt_queue and len(self.mt_queue[0]) > MT_MAX:
            code = 1  # the MT message waiting is too big to transfer
        elif self.mt_queue:
            self.mt_buffer = self.mt_queue.pop(0)
            self.mtmsn = (self.mtmsn + 1) % MOMSN_WRAP
            mt_status, length = 1, len(self.mt_buffer)
        self.ring_flag = False
        line = f"{name}: {code}, {momsn}, {mt_status}, {self.mtmsn}, {length}, {len(self.mt_queue)}"
        self._answer([line], "OK", extra_delay=self.faults.session_delay_s)

    def _read_binary(self) -> None:
        frame = encode_frame(self.mt_buffer or b"")
        if self.faults.corrupt_frame:
            self.faults.corrupt_frame = False
            frame = frame[:-1] + bytes([frame[-1] ^ 0xFF])
        prefix = self._junk_line() if self.faults.garbage else b""
        self._emit(prefix + frame + b"\r\nOK\r\n")

    # -- output ---------------------------------------------------------------------------------

    def _answer(self, lines: list[str], final: str, extra_delay: float = 0.0) -> None:
        out = bytearray(self._junk_line() if self.faults.garbage else b"")
        for line in lines:
            out += f"\r\n{line}\r\n".encode("latin-1")
        out += f"\r\n{final}\r\n".encode("latin-1")
        self._emit(bytes(out), extra_delay=extra_delay)

    def _junk(self, size: int) -> bytes:
        # From 0x80 up: no CR, LF or ASCII that could pass for an answer.
        return bytes(self._rng.randrange(0x80, 0x100) for _ in range(size))

    def _junk_line(self) -> bytes:
        return b"\r\n" + self._junk(12) + b"\r\n"

    def _emit(self, data: bytes, delay: bool = True, extra_delay: float = 0.0) -> None:
        """Queue answer bytes; an answer never overtakes an earlier one (rings may)."""
        due = self.clock() + (self.faults.delay_s if delay else 0.0) + extra_delay
        due = max(due, self._last_due)
        self._last_due = due
        self._out.append((due, data))


class SbdModemServer:
    """Serve a :class:`SimulatedSbdModem` on a pty; ``url`` is the slave device to open."""

    POLL_S = 0.01

    def __init__(self, modem: SimulatedSbdModem) -> None:
        self.modem = modem
        self._stop = threading.Event()
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.url = os.ttyname(self._slave)
        self._thread = threading.Thread(target=self._run, name="sbd-sim", daemon=True)

    def start(self) -> SbdModemServer:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(5)
        for fd in (self._master, self._slave):
            if fd >= 0:
                os.close(fd)
        self._master = self._slave = -1

    def __enter__(self) -> SbdModemServer:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()

    def _run(self) -> None:
        fd = self._master
        while not self._stop.is_set():
            try:
                readable, _, _ = select.select([fd], [], [], self.POLL_S)
                if readable:
                    self.modem.receive(os.read(fd, 4096))
                out = self.modem.take_output()
                if out:
                    os.write(fd, out)
            except OSError:
                if self._stop.is_set():
                    return
                time.sleep(self.POLL_S)  # no reader on the slave side yet


# -- python -m edge_client.sbd.simulator -----------------------------------------------------------


def main(argv: Sequence[str] | None = None, out: TextIO | None = None) -> int:
    """Run a simulated modem on a pty until stdin closes (or ``--duration``)."""
    out = out or sys.stdout
    parser = argparse.ArgumentParser(prog="python -m edge_client.sbd.simulator")
    parser.add_argument("--signal", type=int, default=4, help="bars for AT+CSQ (0-5)")
    parser.add_argument("--no-network", action="store_true", help="every session fails (32)")
    parser.add_argument("--session-delay", type=float, default=0.0, help="seconds per session")
    parser.add_argument("--garbage", action="store_true", help="a junk line before every answer")
    parser.add_argument("--duration", type=float, help="stop after this many seconds")
    args = parser.parse_args(argv)
    modem = SimulatedSbdModem(signal=args.signal, network=not args.no_network)
    modem.faults.session_delay_s = args.session_delay
    modem.faults.garbage = args.garbage
    server = SbdModemServer(modem).start()
    print(server.url, file=out, flush=True)
    deadline = time.monotonic() + args.duration if args.duration is not None else float("inf")
    reported, stdin_open = 0, True
    try:
        while time.monotonic() < deadline:
            if stdin_open and select.select([sys.stdin], [], [], 0.1)[0]:
                line = sys.stdin.readline()
                stdin_open = bool(line)
                if line.strip():
                    print(control(modem, line.strip()), file=out, flush=True)
            elif not stdin_open:
                time.sleep(0.1)
            for message in modem.received[reported:]:
                what = f"{message.data!r}" if message.data else "(mailbox check)"
                print(f"MO momsn={message.momsn} {what}", file=out, flush=True)
                reported += 1
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    return 0


def control(modem: SimulatedSbdModem, line: str) -> str:
    """One operator line: ``mt TEXT``, ``mthex HEX``, ``network on|off``, ``fail N``,
    ``signal N``, ``garbage``, ``deaf S``."""
    word, _space, rest = line.partition(" ")
    try:
        if word == "mt":
            modem.queue_mt(rest.encode())
        elif word == "mthex":
            modem.queue_mt(bytes.fromhex(rest))
        elif word == "network":
            modem.network = rest.strip() != "off"
        elif word == "fail":
            modem.fail_codes.append(int(rest))
        elif word == "signal":
            modem.signal = max(0, min(5, int(rest)))
        elif word == "garbage":
            modem.garbage()
        elif word == "deaf":
            modem.go_deaf(float(rest or 5))
        else:
            return f"unknown: {word} (mt, mthex, network, fail, signal, garbage, deaf)"
    except ValueError as exc:
        return f"bad value: {exc}"
    return f"ok: {line}"


if __name__ == "__main__":
    sys.exit(main())
